//! Real instancing: a glTF mesh placed by several nodes is stored and put in a BVH once
//! (`Scene::prototypes`, `Scene::instances`, the two-level `Accel`). Renders of instanced
//! scenes must match the same scenes with every copy flattened, whatever the material (glossy,
//! emissive, alpha-blended; per-object visibility kept); still mirrored copies stay flattened,
//! moving ones are mirrored instances; and
//! 50,000 instances of a 20,000-triangle mesh
//! load and render at 96×64 in seconds and little memory.

use crate::support::binary::base64;
use crate::support::gltf;
use crate::support::scenes;

use photon::render::{Method, RenderSettings};
use photon::scene::gltf::{load_slice, LoadOptions};
use photon::scene::Scene;
use serde_json::{json, Value};
use std::time::Instant;

/// A .glb of one grid mesh (`n` × `n` quads in the XY plane, 1 m wide, normals +Z) placed by
/// `placements` nodes (each a JSON node without "mesh"), a grey floor, a sun and a camera.
/// With `copies`, every node gets its own mesh (same data): the flattened reference.
fn grid_glb(n: usize, placements: &[Value], copies: bool, material: Value) -> Vec<u8> {
    let mut bin: Vec<u8> = Vec::new();
    let mut push = |bytes: &[u8]| {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let offset = bin.len();
        bin.extend_from_slice(bytes);
        (offset, bytes.len())
    };
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (i as f32 / n as f32 - 0.5, j as f32 / n as f32 - 0.5);
            // A gentle bump so that normals and heights vary.
            let z = 0.1 * ((6.0 * x).sin() * (5.0 * y).cos());
            positions.extend([x, y, z]);
            normals.extend([0.0f32, 0.0, 1.0]);
        }
    }
    let mut indices = Vec::new();
    for j in 0..n as u32 {
        for i in 0..n as u32 {
            let a = j * (n as u32 + 1) + i;
            let (b, c, d) = (a + 1, a + n as u32 + 2, a + n as u32 + 1);
            indices.extend([a, b, c, a, c, d]);
        }
    }
    let floats = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let (p_off, p_len) = push(&floats(&positions));
    let (n_off, n_len) = push(&floats(&normals));
    let ints: Vec<u8> = indices.iter().flat_map(|x| x.to_le_bytes()).collect();
    let (i_off, i_len) = push(&ints);
    let floor = [
        -50.0f32, -50.0, -0.5, 50.0, -50.0, -0.5, 50.0, 50.0, -0.5, -50.0, 50.0, -0.5,
    ];
    let (f_off, f_len) = push(&floats(&floor));
    let (fi_off, fi_len) = push(&[0u32, 1, 2, 0, 2, 3].map(u32::to_le_bytes).concat());
    let vertex_count = (n + 1) * (n + 1);
    let mut doc = json!({
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": []}],
        "extensionsUsed": ["KHR_lights_punctual", "PHOTON_material_nodes"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "directional", "intensity": 2049.0}]}},
        "materials": [material, {"pbrMetallicRoughness":
            {"baseColorFactor": [0.5, 0.5, 0.5, 1.0], "metallicFactor": 0.0}}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": p_off, "byteLength": p_len},
            {"buffer": 0, "byteOffset": n_off, "byteLength": n_len},
            {"buffer": 0, "byteOffset": i_off, "byteLength": i_len},
            {"buffer": 0, "byteOffset": f_off, "byteLength": f_len},
            {"buffer": 0, "byteOffset": fi_off, "byteLength": fi_len}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": vertex_count, "type": "VEC3",
             "min": [-0.5, -0.5, -0.1], "max": [0.5, 0.5, 0.1]},
            {"bufferView": 1, "componentType": 5126, "count": vertex_count, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5125, "count": indices.len(), "type": "SCALAR"},
            {"bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [-50.0, -50.0, -0.5], "max": [50.0, 50.0, -0.5]},
            {"bufferView": 4, "componentType": 5125, "count": 6, "type": "SCALAR"}],
        "meshes": [{"name": "Floor", "primitives": [
            {"attributes": {"POSITION": 3}, "indices": 4, "material": 1}]}],
        "nodes": [
            {"name": "Floor", "mesh": 0},
            {"name": "Sun", "rotation": [-0.3, 0.2, 0.1, 0.93],
             "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"name": "Camera", "camera": 0, "translation": [0.0, -6.0, 9.0],
             "rotation": [0.3826834, 0.0, 0.0, 0.9238795]}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.9, "znear": 0.1}}],
    });
    let grid = json!({"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0});
    let mut roots = vec![0, 1, 2];
    for (k, placement) in placements.iter().enumerate() {
        let mesh = if copies || k == 0 {
            let meshes = doc["meshes"].as_array_mut().unwrap();
            meshes.push(json!({"name": format!("Grid{k}"), "primitives": [grid.clone()]}));
            meshes.len() - 1
        } else {
            1
        };
        let mut node = placement.clone();
        node["mesh"] = json!(mesh);
        let nodes = doc["nodes"].as_array_mut().unwrap();
        nodes.push(node);
        roots.push(nodes.len() - 1);
    }
    doc["scenes"][0]["nodes"] = json!(roots);
    doc["buffers"] = json!([{"byteLength": bin.len()}]);
    gltf::glb(&doc, &bin)
}

fn load(glb: &[u8]) -> Scene {
    load_slice(glb, "instances.glb", &LoadOptions::default()).expect("the file loads")
}

fn grey() -> Value {
    json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.3, 0.2, 1.0],
        "metallicFactor": 0.0, "roughnessFactor": 0.6}})
}

/// Rotated, scaled (also non-uniformly) and translated placements around the origin.
fn placements() -> Vec<Value> {
    let mut out = Vec::new();
    for k in 0..7 {
        let a = k as f32 * 0.9;
        let (s, c) = ((0.5 * a).sin(), (0.5 * a).cos());
        let norm = (0.09 * s * s + s * s + c * c).sqrt();
        out.push(
            json!({"translation": [2.5 * a.cos(), 2.5 * a.sin(), 0.3 * k as f32],
            "rotation": [0.3 * s / norm, 0.0, s / norm, c / norm],
            "scale": [1.0 + 0.2 * k as f32, 1.5, 1.0]}),
        );
    }
    out
}

fn render(scene: &Scene, method: Method) -> Vec<[f32; 4]> {
    let settings = RenderSettings {
        width: 48,
        height: 32,
        spp: 64,
        method,
        ..RenderSettings::default()
    };
    scenes::render_quietly(scene, &settings).unwrap().0.rgba
}

#[test]
fn shared_meshes_become_prototypes_and_render_as_their_copies() {
    let instanced = load(&grid_glb(12, &placements(), false, grey()));
    let flat = load(&grid_glb(12, &placements(), true, grey()));
    assert_eq!(
        (instanced.prototypes.len(), instanced.instances.len()),
        (1, 7)
    );
    assert!(flat.instances.is_empty() && flat.prototypes.is_empty());
    assert_eq!(instanced.placed_triangle_count(), flat.triangle_count());
    let (a, b) = (instanced.bounds(), flat.bounds());
    // Instance bounds are the transformed corners of the prototype's box: they contain the
    // flattened geometry's bounds.
    assert!(
        a.min.cmple(b.min + 1e-4).all() && a.max.cmpge(b.max - 1e-4).all(),
        "{a:?} {b:?}"
    );
    assert_renders_alike(
        "grey",
        &instanced,
        &flat,
        &[Method::Path, Method::Photon],
        0.005,
    );
}

/// `instanced` and `flat` rendered by each of `methods` (same seed) agree within noise: mean
/// within 1 %, relMSE below `rel_mse_max`.
fn assert_renders_alike(
    name: &str,
    instanced: &Scene,
    flat: &Scene,
    methods: &[Method],
    rel_mse_max: f64,
) {
    for &method in methods {
        let (x, y) = (render(instanced, method), render(flat, method));
        let (mut sum_x, mut sum_y, mut err) = (0.0f64, 0.0f64, 0.0f64);
        for (p, q) in x.iter().zip(&y) {
            for c in 0..3 {
                sum_x += p[c] as f64;
                sum_y += q[c] as f64;
                err += ((p[c] - q[c]) as f64).powi(2) / ((q[c] as f64).powi(2) + 1e-2);
            }
        }
        let ratio = sum_x / sum_y;
        let rel_mse = err / (3 * x.len()) as f64;
        println!("{name} {method:?}: mean ratio {ratio:.4}, relMSE {rel_mse:.5}");
        assert!(
            (ratio - 1.0).abs() < 0.01 && rel_mse < rel_mse_max,
            "{name} {method:?}: {ratio} {rel_mse}"
        );
    }
}

/// A node tree emitting a Checker Texture of the Texture Coordinate node's `output` (object
/// coordinates or normals, which instances must read in their own object space).
fn checker_on(output: &str) -> Value {
    json!({"extensions": {"PHOTON_material_nodes": {
        "nodes": [
            {"name": "Coords", "type": "ShaderNodeTexCoord"},
            {"name": "Checker", "type": "ShaderNodeTexChecker",
             "inputs": {"Vector": {"node": 0, "output": output}, "Scale": 2.5,
                        "Color1": [0.9, 0.3, 0.1, 1.0], "Color2": [0.05, 0.2, 0.6, 1.0]}},
            {"name": "Emission", "type": "ShaderNodeEmission",
             "inputs": {"Color": {"node": 1, "output": "Color"}, "Strength": 2.0}}
        ],
        "output": {"node": 2, "output": "Emission"}
    }}})
}

/// Any material may be a prototype: glossy, emissive (sampled as a light where each instance
/// is), alpha-blended and node-tree meshes render as their flattened copies, and a copy hidden from the
/// camera stays hidden. Mirrored copies are flattened.
#[test]
fn instances_of_any_material_render_as_their_copies() {
    let mut places = placements();
    places[2]["extensions"] = json!({"PHOTON_object": {"visible_camera": false}});
    let materials = [
        (
            "glossy",
            json!({"pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.8, 0.5, 1.0],
                "metallicFactor": 1.0, "roughnessFactor": 0.1}}),
        ),
        (
            "emissive",
            json!({"emissiveFactor": [1.0, 0.6, 0.3], "doubleSided": true,
                "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 8.0}},
                "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.2, 0.2, 1.0]}}),
        ),
        (
            "blended",
            json!({"alphaMode": "BLEND", "pbrMetallicRoughness":
                {"baseColorFactor": [0.2, 0.6, 0.9, 0.5], "roughnessFactor": 0.5}}),
        ),
        (
            "translucent (random walk)",
            json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.6, 0.5, 1.0],
                "roughnessFactor": 0.5},
                "extensions": {"PHOTON_material_subsurface": {"weight": 1.0,
                    "radius": [1.0, 0.4, 0.2], "scale": 0.05}}}),
        ),
        ("node tree (object)", checker_on("Object")),
        ("node tree (normal)", checker_on("Normal")),
    ];
    for (name, material) in materials {
        let instanced = load(&grid_glb(12, &places, false, material.clone()));
        let flat = load(&grid_glb(12, &places, true, material));
        assert_eq!(
            (instanced.prototypes.len(), instanced.instances.len()),
            (1, 7),
            "{name}"
        );
        assert_eq!(
            instanced.materials[0].nodes.is_some(),
            name.starts_with("node tree"),
            "{name}"
        );
        assert_eq!(
            instanced.materials[0].is_translucent(),
            name.starts_with("translucent"),
            "{name}"
        );
        let methods: &[Method] = if name == "emissive" || name.starts_with("translucent") {
            &[Method::Path, Method::Photon]
        } else {
            &[Method::Path]
        };
        assert_renders_alike(name, &instanced, &flat, methods, 0.01);
        if name == "emissive" {
            // The grids light the floor: most of the image is their light.
            let lit: f32 = render(&instanced, Method::Path).iter().map(|p| p[0]).sum();
            let grey: f32 = render(&load(&grid_glb(12, &places, false, grey())), Method::Path)
                .iter()
                .map(|p| p[0])
                .sum();
            assert!(lit > 2.0 * grey, "{lit} {grey}");
        }
    }
    let mut places = placements();
    places[1]["scale"] = json!([-1.0, 1.0, 1.0]);
    let scene = load(&grid_glb(4, &places, false, grey()));
    assert_eq!((scene.instances.len(), scene.meshes.len()), (6, 1 + 1));
}

/// A node that moves while the shutter is open (PHOTON_object "motion") is an instance even
/// when its mesh is placed once: rays meet it where it is at their moment, and its bounds cover
/// its whole path. A moving mirrored node is a mirrored instance; a singular one stays put,
/// with a warning.
#[test]
fn moving_nodes_are_met_where_they_are_at_the_ray_moment() {
    use photon::accel::{Accel, Ray, Visibility};
    use photon::math::Vec3;
    let pose = |x: f32| {
        json!([1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, x, 0.0, 0.0, 1.0])
    };
    let moving = json!({"extensions": {"PHOTON_object": {
        "motion": [pose(0.0), pose(2.0), pose(4.0)]}}});
    let scene = load(&grid_glb(4, std::slice::from_ref(&moving), false, grey()));
    assert_eq!(
        (scene.instances.len(), scene.instances[0].motion.len()),
        (1, 3)
    );
    let bounds = scene.bounds();
    assert!(bounds.min.x <= -0.5 && bounds.max.x >= 4.5, "{bounds:?}");
    let accel = Accel::new(&scene);
    // Straight down onto the grid's plane (z ≈ 0) at x = 3.
    let down = |time: f32| Ray {
        origin: Vec3::new(3.0, 0.0, 2.0),
        direction: Vec3::NEG_Z,
        t_max: f32::INFINITY,
        time,
    };
    let on_grid = |time: f32| {
        accel
            .intersect(&scene, &down(time), Visibility::Camera)
            .is_some_and(|h| h.instance == 0)
    };
    assert!(
        !on_grid(0.0),
        "at the opening the grid spans x in [-0.5, 0.5]"
    );
    assert!(
        on_grid(0.75),
        "at 3/4 of the shutter it is centred on x = 3"
    );
    assert!(!on_grid(0.25));
    // Shadow rays down to z = −0.3, above the floor (z = −0.5).
    assert!(!accel.unoccluded(
        &scene,
        &Ray {
            t_max: 2.3,
            ..down(0.75)
        }
    ));
    assert!(accel.unoccluded(
        &scene,
        &Ray {
            t_max: 2.3,
            ..down(0.0)
        }
    ));

    // A moving mirrored node is a mirrored instance that renders as its flattened still copy
    // (here its poses are all the same mirrored transform), also as a one-sided emitter.
    let mirror =
        json!([-1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.5, 0.2, 0.3, 1.0]);
    let still = json!({"matrix": mirror.clone()});
    let mut moving_mirror = still.clone();
    moving_mirror["extensions"] = json!({"PHOTON_object": {"motion": [mirror, mirror]}});
    let emissive = json!({"emissiveFactor": [1.0, 0.6, 0.3],
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 8.0}}});
    for (name, material) in [("grey", grey()), ("one-sided emitter", emissive)] {
        let instanced = load(&grid_glb(
            12,
            &[moving_mirror.clone()],
            false,
            material.clone(),
        ));
        let flat = load(&grid_glb(12, std::slice::from_ref(&still), false, material));
        assert!(instanced.instances.len() == 1 && instanced.instances[0].mirrored);
        assert!(flat.instances.is_empty());
        assert_renders_alike(name, &instanced, &flat, &[Method::Path], 0.01);
    }
    // A singular moving node stays put, with a warning.
    let mut singular = moving.clone();
    singular["scale"] = json!([0.0, 1.0, 1.0]);
    let scene = load(&grid_glb(4, &[singular], false, grey()));
    assert!(scene.instances.is_empty());
    assert!(
        scene.warnings.iter().any(|w| w.contains("motion blur")),
        "{:?}",
        scene.warnings
    );
}

/// Peak resident memory of this process (Linux), in bytes.
fn peak_rss() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

#[test]
fn fifty_thousand_instances_of_twenty_thousand_triangles() {
    // 100 × 100 quads = 20,000 triangles, placed 50,000 times (a billion triangles flattened).
    let side = 224; // 224² = 50,176
    let mut places = Vec::with_capacity(side * side);
    for j in 0..side {
        for i in 0..side {
            let (x, y) = (i as f32 - side as f32 / 2.0, j as f32 - side as f32 / 2.0);
            let half = 0.3 * (0.1 * (i + j) as f32).sin();
            places.push(json!({"translation": [0.05 * x, 0.05 * y, 0.0],
                "rotation": [0.0, 0.0, half.sin(), half.cos()],
                "scale": [0.04, 0.04, 0.04]}));
        }
    }
    let glb = grid_glb(100, &places[..50_000], false, grey());
    let start = Instant::now();
    let scene = load(&glb);
    let loaded = start.elapsed();
    assert_eq!(scene.instances.len(), 50_000);
    assert_eq!(scene.triangle_count(), 20_000 + 2);
    assert_eq!(scene.placed_triangle_count(), 1_000_000_000 + 2);
    let settings = RenderSettings {
        width: 96,
        height: 64,
        spp: 4,
        method: Method::Path,
        ..RenderSettings::default()
    };
    let (image, _) = scenes::render_quietly(&scene, &settings).unwrap();
    let total = start.elapsed();
    let mean: f32 =
        image.rgba.iter().map(|p| p[0] + p[1] + p[2]).sum::<f32>() / image.rgba.len() as f32;
    let rss = peak_rss().unwrap_or(0);
    println!(
        "50,000 instances of 20,000 triangles: load {:.2} s, load + render 96x64 4 spp {:.2} s, \
         peak RSS {:.0} MiB, mean {mean:.4}",
        loaded.as_secs_f32(),
        total.as_secs_f32(),
        rss as f64 / (1 << 20) as f64
    );
    assert!(mean.is_finite() && mean > 0.0);
    assert!(total.as_secs_f32() < 60.0, "{total:?}");
    assert!(rss < 2 << 30, "peak RSS {rss} bytes");
}

/// A node whose mesh deforms while the shutter is open (PHOTON_object "deform": its vertices
/// at the frame and at three steps, here the grid sliding 0, 2 and 4 m along x) is a
/// prototype whose triangles rays meet where they are at their moment; malformed steps are
/// refused.
#[test]
fn deforming_meshes_are_met_where_their_vertices_are_at_the_ray_moment() {
    use photon::accel::{Accel, Ray, Visibility};
    use photon::math::Vec3;
    let n = 4;
    // The grid's vertices as `grid_glb` writes them (in a different order: found by position).
    let mut frame = Vec::new();
    for j in (0..=n).rev() {
        for i in 0..=n {
            let (x, y) = (i as f32 / n as f32 - 0.5, j as f32 / n as f32 - 0.5);
            frame.push([x, y, 0.1 * ((6.0 * x).sin() * (5.0 * y).cos())]);
        }
    }
    let encode = |dx: f32| {
        let bytes: Vec<u8> = frame
            .iter()
            .flat_map(|p| [p[0] + dx, p[1], p[2]])
            .flat_map(f32::to_le_bytes)
            .collect();
        base64(&bytes)
    };
    let deform = json!({"frame": encode(0.0), "steps": [encode(0.0), encode(2.0), encode(4.0)]});
    let node = json!({"extensions": {"PHOTON_object": {"deform": deform}}});
    let scene = load(&grid_glb(n, std::slice::from_ref(&node), false, grey()));
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    assert_eq!((scene.instances.len(), scene.prototypes.len()), (1, 1));
    assert_eq!(scene.prototypes[0].deformation.len(), 3);
    assert!(scene.has_motion());
    let bounds = scene.bounds();
    assert!(bounds.min.x <= -0.5 && bounds.max.x >= 4.5, "{bounds:?}");
    let accel = Accel::new(&scene);
    let on_grid = |time: f32| {
        let ray = Ray {
            origin: Vec3::new(3.0, 0.0, 2.0),
            direction: Vec3::NEG_Z,
            t_max: f32::INFINITY,
            time,
        };
        accel
            .intersect(&scene, &ray, Visibility::Camera)
            .is_some_and(|h| h.instance == 0)
    };
    assert!(!on_grid(0.0) && !on_grid(0.25) && on_grid(0.75) && !on_grid(1.0));

    // Steps of another length, too few steps, bad base64: refused.
    for bad in [
        json!({"frame": encode(0.0), "steps": [encode(0.0), base64(&[0; 12])]}),
        json!({"frame": encode(0.0), "steps": [encode(0.0)]}),
        json!({"frame": "not base64!", "steps": [encode(0.0), encode(1.0)]}),
    ] {
        let node = json!({"extensions": {"PHOTON_object": {"deform": bad}}});
        let result = load_slice(
            &grid_glb(n, &[node], false, grey()),
            "deform.glb",
            &LoadOptions::default(),
        );
        assert!(
            result
                .as_ref()
                .is_err_and(|e| e.to_string().contains("deform")),
            "{:?}",
            result.err()
        );
    }
    // Vertices that are not the frame's: kept still, with a warning.
    let moved = json!({"frame": encode(0.5), "steps": [encode(0.0), encode(1.0)]});
    let node = json!({"extensions": {"PHOTON_object": {"deform": moved}}});
    let scene = load(&grid_glb(n, &[node], false, grey()));
    assert!(scene.prototypes[0].deformation.is_empty());
    assert!(scene.warnings.iter().any(|w| w.contains("deformation")));
}
