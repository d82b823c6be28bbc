//! Whole node trees compiled and evaluated (the tests of one node family sit in its file), and
//! Blender's own Noise and Voronoi values at chosen points.

use super::noise::{noise_texture, Fractal};
use super::program::Op;
use super::voronoi::{voronoi, CellHash, Metric, VoronoiFeature, VoronoiKind, VoronoiParams};
use super::*;
use crate::math::{Vec2, Vec3, Vec4};
use serde_json::{json, Value};

fn at_generated(p: Vec3) -> ShadingInputs {
    ShadingInputs::at_point(PointInputs {
        generated: p,
        ..PointInputs::default()
    })
}

/// Shading inputs with `normal` at the three `positions` (the point, then its offsets).
fn at_positions(positions: [Vec3; 3], normal: Vec3) -> ShadingInputs {
    ShadingInputs {
        points: positions.map(|position| PointInputs {
            position,
            ..PointInputs::default()
        }),
        normal,
        ..ShadingInputs::default()
    }
}

fn emission_of(tree: Value, at: &ShadingInputs) -> Vec3 {
    let mut w = Vec::new();
    let program = compile(&tree, 0, &mut w).expect("compiles");
    program.eval(at, &[], 0.5).emission
}

#[test]
fn displacement_bumps_the_normal_the_surface_reads() {
    // Height = x along the normal, as the add-on writes "Bump Only": the normal tilts to
    // (−1, 0, 1)/√2, and the surface's Geometry Normal (into Emission) reads it.
    let displacement = json!({"nodes": [
        {"name": "G", "type": "ShaderNodeNewGeometry"},
        {"name": "X", "type": "ShaderNodeSeparateXYZ",
         "inputs": {"Vector": {"node": 0, "output": "Position"}}},
        {"name": "D", "type": "ShaderNodeDisplacement", "space": "WORLD",
         "inputs": {"Height": {"node": 1, "output": "X"}, "Midlevel": 0.0, "Scale": 1.0}},
        {"name": "N", "type": "ShaderNodeNewGeometry"},
        {"name": "H", "type": "ShaderNodeVectorMath", "operation": "DOT_PRODUCT",
         "inputs": {"Vector": {"node": 2, "output": "Displacement"},
                    "Vector_001": {"node": 3, "output": "Normal"}}},
        {"name": "B", "type": "ShaderNodeBump", "inputs": {
            "Strength": 1.0, "Distance": 1.0, "Height": {"node": 4, "output": "Value"}}}
    ], "output": {"node": 5, "output": "Normal"}});
    let tree = json!({"nodes": [
        {"name": "G", "type": "ShaderNodeNewGeometry"},
        {"name": "E", "type": "ShaderNodeEmission",
         "inputs": {"Color": {"node": 0, "output": "Normal"}, "Strength": 1.0}}
    ], "output": {"node": 1, "output": "Emission"}, "displacement": displacement});
    let mut w = Vec::new();
    let program = compile(&tree, 0, &mut w).expect("compiles");
    assert!(w.is_empty() && program.needs_offsets, "{w:?}");
    let at = at_positions([Vec3::ZERO, Vec3::X * 1e-3, Vec3::Y * 1e-3], Vec3::Z);
    let c = program.eval(&at, &[], 0.5);
    let expected = Vec3::new(-1.0, 0.0, 1.0).normalize();
    assert!((c.emission - expected).length() < 1e-3, "{}", c.emission);
    assert!((c.normal - expected).length() < 1e-3, "{}", c.normal);
}

#[test]
fn light_path_outputs_read_the_ray_path() {
    let output = |name: &str, path: RayPath| {
        let tree = json!({"nodes": [
            {"name": "L", "type": "ShaderNodeLightPath"},
            {"name": "E", "type": "ShaderNodeEmission",
             "inputs": {"Color": {"node": 0, "output": name}, "Strength": 1.0}}
        ], "output": {"node": 1, "output": "Emission"}});
        let at = ShadingInputs {
            path,
            ray_length: 2.5,
            ..ShadingInputs::default()
        };
        emission_of(tree, &at).x
    };
    let p = RayPath::camera()
        .after(Scattering::Transparent, true)
        .after(Scattering::Transparent, true)
        .after(Scattering::Singular, true)
        .after(Scattering::Diffuse, false);
    let expected = [
        ("Is Camera Ray", 0.0),
        ("Is Shadow Ray", 0.0),
        ("Is Diffuse Ray", 1.0),
        ("Is Glossy Ray", 0.0),
        ("Is Singular Ray", 0.0),
        ("Is Reflection Ray", 1.0),
        ("Is Transmission Ray", 0.0),
        ("Is Volume Scatter Ray", 0.0),
        ("Ray Length", 2.5),
        ("Ray Depth", 2.0),
        ("Diffuse Depth", 1.0),
        ("Glossy Depth", 0.0),
        ("Transparent Depth", 2.0),
        ("Transmission Depth", 1.0),
    ];
    for (name, value) in expected {
        assert_eq!(output(name, p), value, "{name}");
    }
    assert_eq!(output("Is Shadow Ray", p.shadow()), 1.0);
    assert_eq!(output("Is Camera Ray", RayPath::camera()), 1.0);
    // Only the outputs of a camera path's state make the tree depend on it.
    for (name, depends) in [
        ("Is Camera Ray", false),
        ("Is Shadow Ray", false),
        ("Ray Length", false),
        ("Is Glossy Ray", true),
        ("Transparent Depth", true),
    ] {
        let tree = json!({"nodes": [
            {"name": "L", "type": "ShaderNodeLightPath"},
            {"name": "E", "type": "ShaderNodeEmission",
             "inputs": {"Color": {"node": 0, "output": name}}}
        ], "output": {"node": 1, "output": "Emission"}});
        let program = compile(&tree, 0, &mut Vec::new()).expect("compiles");
        assert_eq!(program.reads_ray_state, depends, "{name}");
    }
}

#[test]
fn only_reflecting_and_refracting_bsdfs_may_be_smooth() {
    for (kind, output, smooth) in [
        ("ShaderNodeBsdfTransparent", "BSDF", false),
        ("ShaderNodeBsdfDiffuse", "BSDF", false),
        ("ShaderNodeEmission", "Emission", false),
        ("ShaderNodeBsdfGlass", "BSDF", true),
        ("ShaderNodeBsdfRefraction", "BSDF", true),
        ("ShaderNodeBsdfPrincipled", "BSDF", true),
    ] {
        let tree = json!({"nodes": [{"name": "S", "type": kind}],
                          "output": {"node": 0, "output": output}});
        let program = compile(&tree, 0, &mut Vec::new()).expect("compiles");
        assert_eq!(program.may_be_smooth, smooth, "{kind}");
    }
}

#[test]
fn transparent_closures_let_shadows_through() {
    let tree = |alpha: Value| {
        json!({"nodes": [
            {"name": "P", "type": "ShaderNodeBsdfPrincipled", "inputs": {"Alpha": alpha}}
        ], "output": {"node": 0, "output": "BSDF"}})
    };
    let compiled = |t: Value| compile(&t, 0, &mut Vec::new()).expect("compiles");
    assert!(!compiled(tree(json!(1.0))).shadow_transparent);
    assert!(compiled(tree(json!(0.5))).shadow_transparent);
    let transparent = json!({"nodes": [
        {"name": "T", "type": "ShaderNodeBsdfTransparent", "inputs": {"Color": [1, 1, 1, 1]}}
    ], "output": {"node": 0, "output": "BSDF"}});
    let program = compiled(transparent);
    assert!(program.shadow_transparent);
    let c = program.eval(&ShadingInputs::default(), &[], 0.5);
    assert!(c.transparent && c.transmission == 1.0);
}

#[test]
fn checker_tree_into_emission() {
    let tree = json!({
        "nodes": [
            {"name": "Checker", "type": "ShaderNodeTexChecker",
             "inputs": {"Color1": [1.0, 0.0, 0.0, 1.0], "Color2": [0.0, 0.0, 1.0, 1.0],
                        "Scale": 2.0}},
            {"name": "Emission", "type": "ShaderNodeEmission",
             "inputs": {"Color": {"node": 0, "output": "Color"}, "Strength": 3.0}}
        ],
        "output": {"node": 1, "output": "Emission"}
    });
    let e = emission_of(tree.clone(), &at_generated(Vec3::new(0.1, 0.1, 0.1)));
    assert_eq!(e, Vec3::new(0.0, 0.0, 3.0));
    let e = emission_of(tree, &at_generated(Vec3::new(0.6, 0.1, 0.1)));
    assert_eq!(e, Vec3::new(3.0, 0.0, 0.0));
}

#[test]
fn math_and_conversions_in_a_tree() {
    // Separate the UV, multiply u by v, feed the float into a colour (float → colour).
    let tree = json!({
        "nodes": [
            {"name": "UV", "type": "ShaderNodeUVMap", "uv_set": 2},
            {"name": "Sep", "type": "ShaderNodeSeparateXYZ",
             "inputs": {"Vector": {"node": 0, "output": "UV"}}},
            {"name": "Mul", "type": "ShaderNodeMath", "operation": "MULTIPLY",
             "inputs": {"Value": {"node": 1, "output": "X"},
                        "Value_001": {"node": 1, "output": "Y"}}},
            {"name": "Col", "type": "ShaderNodeRGB", "value": [0.0, 1.0, 0.0, 1.0]},
            {"name": "Gray", "type": "ShaderNodeMath", "operation": "ADD",
             "inputs": {"Value": {"node": 3, "output": "Color"}, "Value_001": 0.0}},
            {"name": "Sum", "type": "ShaderNodeMath", "operation": "ADD",
             "inputs": {"Value": {"node": 2, "output": "Value"},
                        "Value_001": {"node": 4, "output": "Value"}}},
            {"name": "Emission", "type": "ShaderNodeEmission",
             "inputs": {"Color": {"node": 5, "output": "Value"}}}
        ],
        "output": {"node": 6, "output": "Emission"}
    });
    let at = ShadingInputs::at_point(PointInputs {
        uv: [Vec2::ZERO, Vec2::ONE, Vec2::new(0.5, 0.25), Vec2::ONE],
        ..PointInputs::default()
    });
    let e = emission_of(tree, &at);
    assert!(
        (e - Vec3::splat(0.125 + 0.7152)).abs().max_element() < 1e-6,
        "{e}"
    );
}

#[test]
fn mix_shader_picks_by_factor_and_mixes_emission() {
    let tree = json!({
        "nodes": [
            {"name": "D", "type": "ShaderNodeBsdfDiffuse", "inputs": {"Color": [1.0, 0.0, 0.0, 1.0]}},
            {"name": "G", "type": "ShaderNodeBsdfGlossy", "inputs": {"Color": [0.0, 1.0, 0.0, 1.0], "Roughness": 0.2}},
            {"name": "E", "type": "ShaderNodeEmission", "inputs": {"Strength": 2.0}},
            {"name": "M", "type": "ShaderNodeMixShader", "inputs": {"Fac": 0.25,
                "Shader": {"node": 0, "output": "BSDF"}, "Shader_001": {"node": 1, "output": "BSDF"}}},
            {"name": "A", "type": "ShaderNodeAddShader", "inputs": {
                "Shader": {"node": 3, "output": "Shader"}, "Shader_001": {"node": 2, "output": "Emission"}}}
        ],
        "output": {"node": 4, "output": "Shader"}
    });
    let mut w = Vec::new();
    let p = compile(&tree, 0, &mut w).unwrap();
    let at = ShadingInputs::default();
    let n = 10_000;
    let mut metal = 0;
    for i in 0..n {
        let c = p.eval(&at, &[], (i as f32 + 0.5) / n as f32);
        assert_eq!(c.emission, Vec3::splat(2.0));
        if c.metallic == 1.0 {
            assert_eq!(c.base_color, Vec3::new(0.0, 1.0, 0.0));
            metal += 1;
        } else {
            assert_eq!(c.base_color, Vec3::new(1.0, 0.0, 0.0));
            assert_eq!(c.specular_color, Vec3::ZERO);
        }
    }
    assert_eq!(metal, n / 4);
}

#[test]
fn invalid_programs_are_refused_with_a_reason() {
    let mut w = Vec::new();
    let forward = json!({"nodes": [
        {"name": "E", "type": "ShaderNodeEmission", "inputs": {"Color": {"node": 1, "output": "Color"}}},
        {"name": "C", "type": "ShaderNodeRGB", "value": [1, 1, 1, 1]}
    ], "output": {"node": 0, "output": "Emission"}});
    let e = compile(&forward, 0, &mut w).unwrap_err();
    assert!(e.contains("not earlier"), "{e}");
    let value_as_shader = json!({"nodes": [
        {"name": "C", "type": "ShaderNodeRGB", "value": [1, 1, 1, 1]}
    ], "output": {"node": 0, "output": "Color"}});
    assert!(compile(&value_as_shader, 0, &mut w)
        .unwrap_err()
        .contains("shader output"));
    assert!(compile(&json!({"nodes": 3}), 0, &mut w).is_err());
    let bad_ramp = json!({"nodes": [{"name": "R", "type": "ShaderNodeValToRGB", "table": [1]}]});
    assert!(compile(&bad_ramp, 0, &mut w)
        .unwrap_err()
        .contains("Color Ramp"));
}

#[test]
fn unknown_nodes_warn_and_fall_back() {
    let mut w = Vec::new();
    let tree = json!({"nodes": [
        {"name": "Particles", "type": "ShaderNodeParticleInfo"},
        {"name": "E", "type": "ShaderNodeEmission", "inputs": {
            "Color": {"node": 0, "output": "Velocity"}, "Strength": 1.0}}
    ], "output": {"node": 1, "output": "Emission"}});
    let p = compile(&tree, 0, &mut w).unwrap();
    assert_eq!(w.len(), 1);
    assert!(w[0].contains("Particles"), "{w:?}");
    // The Emission colour's default (white) is used.
    assert_eq!(
        p.eval(&ShadingInputs::default(), &[], 0.5).emission,
        Vec3::ONE
    );
}

#[test]
fn bump_tilts_the_normal_against_the_height_gradient() {
    // Height = world x: the gradient is +X, so with distance 1 the normal leans to −X by
    // 45°; the Height subtree is copied for the two offset points.
    let tree = json!({"nodes": [
        {"name": "Geometry", "type": "ShaderNodeNewGeometry"},
        {"name": "Sep", "type": "ShaderNodeSeparateXYZ",
         "inputs": {"Vector": {"node": 0, "output": "Position"}}},
        {"name": "Bump", "type": "ShaderNodeBump",
         "inputs": {"Distance": 1.0, "Strength": 1.0,
                    "Height": {"node": 1, "output": "X"}}},
        {"name": "D", "type": "ShaderNodeBsdfDiffuse",
         "inputs": {"Normal": {"node": 2, "output": "Normal"}}}
    ], "output": {"node": 3, "output": "BSDF"}});
    let mut w = Vec::new();
    let p = compile(&tree, 0, &mut w).unwrap();
    assert!(p.needs_offsets && w.is_empty());
    let e = 1e-3;
    let c = p.eval(
        &at_positions([Vec3::ZERO, Vec3::X * e, Vec3::Y * e], Vec3::Z),
        &[],
        0.5,
    );
    let want = Vec3::new(-1.0, 0.0, 1.0).normalize();
    assert!((c.normal - want).length() < 1e-4, "{}", c.normal);
    // Without offsets (all three points equal) the normal is the surface's.
    let flat = p.eval(&at_positions([Vec3::ZERO; 3], Vec3::Z), &[], 0.5);
    assert!((flat.normal - Vec3::Z).length() < 1e-6);
}

/// Blender's own Noise and Voronoi values at chosen points (near the origin, negative,
/// −0, on cell walls, large, past Noise's period), recorded by
/// `scenes/blender/record_patterns.py` with Blender's geometry nodes, which evaluate the
/// same definitions as Cycles' shader nodes.
fn blender_patterns() -> (Value, Vec<Vec3>) {
    let doc: Value = serde_json::from_str(include_str!("../../tests/data/blender_patterns.json"))
        .expect("the recorded patterns are JSON");
    let points = doc["points"]
        .as_array()
        .unwrap()
        .iter()
        .map(vec3_of)
        .collect();
    (doc, points)
}

fn dims_of(config: &Value) -> u8 {
    if config["dimensions"] == "2D" {
        2
    } else {
        3
    }
}

fn vec3_of(v: &Value) -> Vec3 {
    let c = |k: usize| v[k].as_f64().expect("a number") as f32;
    Vec3::new(c(0), c(1), c(2))
}

/// |a − b| within 2e-5 of the larger magnitude (at least 1): Blender's build may contract
/// multiply-adds where Photon does not.
fn assert_close(a: Vec3, b: Vec3, what: &str) {
    let scale = a.abs().max(b.abs()).max_element().max(1.0);
    assert!(
        (a - b).abs().max_element() <= 2e-5 * scale,
        "{what}: {a} vs Blender's {b}"
    );
}

#[test]
fn blender_noise_at_chosen_points() {
    let (doc, points) = blender_patterns();
    for n in doc["noise"].as_array().unwrap() {
        let (dims, num) = (dims_of(n), |k: &str| n[k].as_f64().unwrap() as f32);
        let f = Fractal {
            detail: num("detail"),
            roughness: num("roughness"),
            lacunarity: num("lacunarity"),
            normalize: n["normalize"].as_bool().unwrap(),
        };
        for (k, p) in points.iter().enumerate() {
            let (fac, color) = noise_texture(dims, *p, 0.0, &f, num("distortion"), true);
            let what = format!("{n} at {p}");
            let want = n["fac"][k].as_f64().unwrap() as f32;
            assert_close(Vec3::splat(fac), Vec3::splat(want), &what);
            assert_close(color, vec3_of(&n["color"][k]), &what);
        }
    }
}

#[test]
fn blender_voronoi_at_chosen_points() {
    let (doc, points) = blender_patterns();
    for v in doc["voronoi"].as_array().unwrap() {
        let (dims, num) = (dims_of(v), |k: &str| v[k].as_f64().unwrap() as f32);
        let feature = match v["feature"].as_str().unwrap() {
            "F2" => VoronoiFeature::F2,
            "SMOOTH_F1" => VoronoiFeature::SmoothF1,
            _ => VoronoiFeature::F1,
        };
        let metric = match v["metric"].as_str().unwrap() {
            "MANHATTAN" => Metric::Manhattan,
            "CHEBYCHEV" => Metric::Chebychev,
            "MINKOWSKI" => Metric::Minkowski,
            _ => Metric::Euclidean,
        };
        let params = VoronoiParams {
            scale: 1.0,
            detail: num("detail"),
            roughness: 0.5,
            lacunarity: 2.0,
            smoothness: (num("smoothness") / 2.0).clamp(0.0, 0.5),
            exponent: num("exponent"),
            randomness: num("randomness"),
            kind: VoronoiKind {
                dimensions: dims,
                feature,
                metric,
                normalize: false,
                cell_hash: CellHash::Lookup3,
            },
        };
        for (k, p) in points.iter().enumerate() {
            let mut p = *p;
            if dims == 2 {
                p.z = 0.0;
            }
            let (distance, color, position) = voronoi(&params, p, true);
            let what = format!("{v} at {p}");
            let want = v["distance"][k].as_f64().unwrap() as f32;
            assert_close(Vec3::splat(distance), Vec3::splat(want), &what);
            assert_close(color, vec3_of(&v["color"][k]), &what);
            assert_close(position, vec3_of(&v["position"][k]), &what);
        }
    }
}

#[test]
fn a_bumps_noise_copies_fuse_into_one_instruction() {
    // Noise → Bump and Noise → Emission: the Noise and its two offset copies become one
    // NoiseAt3 placed where the Noise was, and the tree's values are unchanged.
    let tree = json!({"nodes": [
        {"name": "T", "type": "ShaderNodeTexCoord"},
        {"name": "N", "type": "ShaderNodeTexNoise", "inputs": {
            "Vector": {"node": 0, "output": "Object"}, "Scale": 3.0, "Detail": 2.0}},
        {"name": "B", "type": "ShaderNodeBump", "inputs": {
            "Distance": 0.1, "Strength": 1.0, "Height": {"node": 1, "output": "Fac"}}},
        {"name": "E", "type": "ShaderNodeEmission", "inputs": {
            "Color": {"node": 1, "output": "Color"}, "Strength": 1.0}},
        {"name": "D", "type": "ShaderNodeBsdfDiffuse",
         "inputs": {"Normal": {"node": 2, "output": "Normal"}}},
        {"name": "A", "type": "ShaderNodeAddShader", "inputs": {
            "Shader": {"node": 3, "output": "Emission"},
            "Shader_001": {"node": 4, "output": "BSDF"}}}
    ], "output": {"node": 5, "output": "Shader"}});
    let mut w = Vec::new();
    let p = compile(&tree, 0, &mut w).unwrap();
    assert!(w.is_empty(), "{w:?}");
    let fused = p
        .instrs
        .iter()
        .filter(|i| matches!(i.op, Op::NoiseAt3 { .. }))
        .count();
    let plain = p
        .instrs
        .iter()
        .filter(|i| matches!(i.op, Op::Noise { .. }))
        .count();
    assert_eq!((fused, plain), (1, 0));
    let q = Vec3::new(0.3, -0.2, 0.1);
    let e = 1e-3;
    let mut at = at_positions([q, q + Vec3::X * e, q + Vec3::Y * e], Vec3::Z);
    for point in &mut at.points {
        point.object = point.position;
    }
    let c = p.eval(&at, &[], 0.5);
    let f = Fractal {
        detail: 2.0,
        roughness: 0.5,
        lacunarity: 2.0,
        normalize: true,
    };
    let (_, color) = noise_texture(3, q * 3.0, 0.0, &f, 0.0, true);
    assert_eq!(c.emission, color);
    let h = |v: Vec3| noise_texture(3, v * 3.0, 0.0, &f, 0.0, false).0;
    let slope = Vec3::new(h(q + Vec3::X * e) - h(q), h(q + Vec3::Y * e) - h(q), 0.0);
    assert!(
        slope.length() > 0.0 && c.normal.dot(slope) < 0.0,
        "{}",
        c.normal
    );
}

#[test]
fn object_info_reads_the_object_and_the_material_index() {
    let output = |name: &str| {
        let tree = json!({"nodes": [
            {"name": "O", "type": "ShaderNodeObjectInfo", "material_index": 4},
            {"name": "E", "type": "ShaderNodeEmission",
             "inputs": {"Color": {"node": 0, "output": name}, "Strength": 1.0}}
        ], "output": {"node": 1, "output": "Emission"}});
        let at = ShadingInputs {
            object: ObjectInfo {
                location: Vec3::new(1.0, -2.0, 3.0),
                color: Vec4::new(0.5, 0.25, 0.125, 0.75),
                pass_index: 6.0,
                random: ObjectInfo::random_of(u32::MAX / 4),
                ..ObjectInfo::default()
            },
            ..ShadingInputs::default()
        };
        emission_of(tree, &at)
    };
    assert_eq!(output("Location"), Vec3::new(1.0, -2.0, 3.0));
    assert_eq!(output("Color"), Vec3::new(0.5, 0.25, 0.125));
    assert_eq!(output("Alpha"), Vec3::splat(0.75));
    assert_eq!(output("Object Index"), Vec3::splat(6.0));
    assert_eq!(output("Material Index"), Vec3::splat(4.0));
    assert!((output("Random").x - 0.25).abs() < 1e-6);
}

#[test]
fn object_instancer_and_view_layer_attributes_read_their_values() {
    // An Attribute node with `settings`, its output `name` into an Emission's colour.
    let tree_of = |settings: &Value, name: &str| {
        let mut node = json!({"name": "A", "type": "ShaderNodeAttribute"});
        node.as_object_mut()
            .unwrap()
            .extend(settings.as_object().unwrap().clone());
        json!({"nodes": [node,
            {"name": "E", "type": "ShaderNodeEmission",
             "inputs": {"Color": {"node": 0, "output": name}, "Strength": 1.0}}
        ], "output": {"node": 1, "output": "Emission"}})
    };
    let output = |attribute: Value, name: &str, object: ObjectInfo| {
        let mut at = ShadingInputs {
            object,
            ..ShadingInputs::default()
        };
        // A vertex colour the object attributes must not read.
        at.points[0].color = Vec4::new(0.9, 0.9, 0.9, 0.9);
        emission_of(tree_of(&attribute, name), &at)
    };
    let mut object = ObjectInfo::default();
    object.attributes[3] = Vec4::new(0.25, 0.5, 0.75, 0.125);
    let slot3 = json!({"attribute_type": "INSTANCER", "attribute_name": "tint", "object_slot": 3});
    assert_eq!(
        output(slot3.clone(), "Color", object),
        Vec3::new(0.25, 0.5, 0.75)
    );
    assert_eq!(
        output(slot3.clone(), "Vector", object),
        Vec3::new(0.25, 0.5, 0.75)
    );
    // Fac is the average of the colour (Cycles' float4 attribute read as a float).
    assert_eq!(output(slot3.clone(), "Fac", object), Vec3::splat(0.5));
    assert_eq!(output(slot3, "Alpha", object), Vec3::splat(0.125));
    // A slot the object has no value in reads zero, as Cycles' attribute found nowhere.
    let slot0 = json!({"attribute_type": "OBJECT", "attribute_name": "x", "object_slot": 0});
    assert_eq!(output(slot0, "Color", object), Vec3::ZERO);
    let layer = json!({"attribute_type": "VIEW_LAYER", "attribute_name": "y",
                       "value": [1.0, 0.0, 0.5, 1.0]});
    assert_eq!(
        output(layer.clone(), "Color", object),
        Vec3::new(1.0, 0.0, 0.5)
    );
    assert_eq!(output(layer, "Fac", object), Vec3::splat(0.5));
    // A slot out of range, or none, refuses the tree.
    for bad in [
        json!({"attribute_type": "OBJECT", "object_slot": 8}),
        json!({"attribute_type": "OBJECT"}),
        json!({"attribute_type": "VIEW_LAYER"}),
        json!({"attribute_type": "ELSEWHERE"}),
    ] {
        assert!(
            compile(&tree_of(&bad, "Color"), 0, &mut Vec::new()).is_err(),
            "{bad}"
        );
    }
}

#[test]
fn ray_portal_sends_the_ray_from_its_position_along_its_direction() {
    let portal = |inputs: Value| {
        let tree = json!({"nodes": [
            {"name": "G", "type": "ShaderNodeNewGeometry"},
            {"name": "M", "type": "ShaderNodeVectorMath", "operation": "ADD",
             "inputs": {"Vector": {"node": 0, "output": "Position"},
                        "Vector_001": [5.0, 0.0, 0.0]}},
            {"name": "P", "type": "ShaderNodeBsdfRayPortal", "inputs": inputs},
        ], "output": {"node": 2, "output": "BSDF"}});
        let program = compile(&tree, 0, &mut Vec::new()).expect("compiles");
        assert!(program.ray_portal && !program.shadow_transparent);
        let at = ShadingInputs {
            incoming: Vec3::new(0.0, 0.6, 0.8),
            ..at_positions([Vec3::new(1.0, 2.0, 0.0); 3], Vec3::Z)
        };
        program.eval(&at, &[], 0.5)
    };
    // Unlinked: on from the point itself, straight on (against the incoming direction).
    let straight = portal(json!({"Color": [0.5, 0.25, 1.0, 1.0]}));
    let p = straight.portal.expect("a portal");
    assert_eq!(p.position, Vec3::new(1.0, 2.0, 0.0));
    assert_eq!(p.direction, Vec3::new(0.0, -0.6, -0.8));
    assert_eq!(straight.base_color, Vec3::new(0.5, 0.25, 1.0));
    // Position linked (the point moved along x), Direction set.
    let moved = portal(json!({"Position": {"node": 1, "output": "Vector"},
                              "Direction": [0.0, 0.0, -1.0]}));
    let p = moved.portal.expect("a portal");
    assert_eq!(p.position, Vec3::new(6.0, 2.0, 0.0));
    assert_eq!(p.direction, -Vec3::Z);
    assert_eq!(moved.base_color, Vec3::ONE);
}

#[test]
fn hair_info_reads_the_tube_attributes_and_zero_off_hair() {
    let output = |name: &str, attributes: NamedAttributes| {
        let tree = json!({"nodes": [
            {"name": "H", "type": "ShaderNodeHairInfo",
             "attributes": {"fibre": "photon_hair", "curve": "photon_hair_curve"}},
            {"name": "E", "type": "ShaderNodeEmission",
             "inputs": {"Color": {"node": 0, "output": name}, "Strength": 1.0}}
        ], "output": {"node": 1, "output": "Emission"}});
        let at = ShadingInputs {
            attributes,
            // The viewer up and ahead of a fibre along x.
            incoming: Vec3::new(0.6, 0.0, 0.8),
            fibre: Vec3::X,
            ..ShadingInputs::default()
        };
        emission_of(tree, &at)
    };
    let mut values = [Vec4::ZERO; NAMED_ATTRIBUTES];
    values[0] = Vec4::new(0.25, 1.5, 0.02, 1.0);
    // The index as a triangle's interpolation may leave it.
    values[1] = Vec4::splat(6.999_999);
    let hair = NamedAttributes {
        values,
        found: 0b11,
    };
    assert_eq!(output("Is Strand", hair), Vec3::ONE);
    assert_eq!(output("Intercept", hair), Vec3::splat(0.25));
    assert_eq!(output("Length", hair), Vec3::splat(1.5));
    assert_eq!(output("Thickness", hair), Vec3::splat(0.02));
    let random = super::hash::unit(super::hash::hash2(7, 0));
    assert_eq!(output("Random", hair), Vec3::splat(random));
    // Tangent Normal: the view made perpendicular to the fibre.
    assert_eq!(output("Tangent Normal", hair), Vec3::Z);
    for name in [
        "Is Strand",
        "Intercept",
        "Length",
        "Thickness",
        "Tangent Normal",
        "Random",
    ] {
        assert_eq!(
            output(name, NamedAttributes::default()),
            Vec3::ZERO,
            "{name}"
        );
    }
}

#[test]
fn metallic_conductor_meets_its_exact_fresnel_at_normal_incidence_and_82_degrees() {
    use super::closure::conductor_fresnel;
    // Copper's complex index: F0 from n and k, and the F82-tint model through both points.
    let (n, k) = (Vec3::new(0.27, 0.68, 1.32), Vec3::new(3.61, 2.63, 2.29));
    let f0 = conductor_fresnel(1.0, n, k);
    let expected =
        ((n - Vec3::ONE) * (n - Vec3::ONE) + k * k) / ((n + Vec3::ONE) * (n + Vec3::ONE) + k * k);
    assert!((f0 - expected).length() < 1e-5, "{f0} {expected}");
    assert!((conductor_fresnel(0.0, n, k) - Vec3::ONE).length() < 1e-5);
    let tree = json!({"nodes": [
        {"name": "M", "type": "ShaderNodeBsdfMetallic", "fresnel_type": "PHYSICAL_CONDUCTOR",
         "inputs": {"IOR": [0.27, 0.68, 1.32], "Extinction": [3.61, 2.63, 2.29]}}
    ], "output": {"node": 0, "output": "BSDF"}});
    let mut w = Vec::new();
    let program = compile(&tree, 0, &mut w).expect("compiles");
    let c = program.eval(&ShadingInputs::default(), &[], 0.5);
    assert!((c.base_color - f0).length() < 1e-5 && c.metallic == 1.0);
    let tint = c.metal_tint.expect("the conductor's F82 tint");
    let mu = 1.0f32 / 7.0;
    let schlick = f0 + (Vec3::ONE - f0) * (1.0 - mu).powi(5);
    assert!((schlick * tint - conductor_fresnel(mu, n, k)).length() < 1e-4);
}

#[test]
fn wireframe_marks_points_within_half_its_size_of_an_edge() {
    let fac = |p: Vec3, pixel_size: bool, pixel_width: f32| {
        let tree = json!({"nodes": [
            {"name": "W", "type": "ShaderNodeWireframe", "use_pixel_size": pixel_size,
             "inputs": {"Size": 0.2}},
            {"name": "E", "type": "ShaderNodeEmission",
             "inputs": {"Color": {"node": 0, "output": "Fac"}, "Strength": 1.0}}
        ], "output": {"node": 1, "output": "Emission"}});
        let mut at = at_positions([p; 3], Vec3::Z);
        at.incoming = Vec3::Z;
        at.triangle = [Vec3::ZERO, Vec3::X, Vec3::Y];
        at.pixel_width = pixel_width;
        emission_of(tree, &at).x
    };
    // 0.05 from the edge along x: within 0.1; 0.25 from every edge: not.
    assert_eq!(fac(Vec3::new(0.5, 0.05, 0.0), false, 0.0), 1.0);
    assert_eq!(fac(Vec3::new(0.25, 0.25, 0.0), false, 0.0), 0.0);
    // In pixels: Size times the footprint (seen straight on, the footprint itself).
    assert_eq!(fac(Vec3::new(0.5, 0.05, 0.0), true, 0.4), 0.0);
    assert_eq!(fac(Vec3::new(0.5, 0.05, 0.0), true, 4.0), 1.0);
}

#[test]
fn toon_is_full_within_its_size_and_fades_over_its_smooth_edge() {
    let toon = Toon {
        size: 0.5,
        smooth: 0.2,
        glossy: false,
    };
    let quarter = std::f32::consts::FRAC_PI_2;
    assert_eq!(toon.intensity(0.4 * quarter), 1.0);
    assert!((toon.intensity(0.6 * quarter) - 0.5).abs() < 1e-5);
    assert_eq!(toon.intensity(0.75 * quarter), 0.0);
    assert!((toon.cos_cone() - (0.7 * quarter).cos()).abs() < 1e-6);
    let tree = json!({"nodes": [
        {"name": "T", "type": "ShaderNodeBsdfToon", "component": "GLOSSY",
         "inputs": {"Color": [0.9, 0.4, 0.2, 1.0], "Size": 0.2, "Smooth": 2.0}}
    ], "output": {"node": 0, "output": "BSDF"}});
    let mut w = Vec::new();
    let c = compile(&tree, 0, &mut w)
        .unwrap()
        .eval(&ShadingInputs::default(), &[], 0.5);
    let expected = Toon {
        size: 0.2,
        smooth: 1.0,
        glossy: true,
    };
    assert_eq!(
        (c.toon, c.base_color),
        (Some(expected), Vec3::new(0.9, 0.4, 0.2))
    );
}

#[test]
fn principled_hair_resolves_melanin_and_its_model() {
    let hair = |settings: Value| {
        let mut node = json!({"name": "H", "type": "ShaderNodeBsdfHairPrincipled",
            "inputs": {"Melanin": 0.8, "Melanin Redness": 1.0, "Roughness": 0.4,
                       "Random Roughness": 0.5, "Random": 1.0}});
        node.as_object_mut()
            .unwrap()
            .extend(settings.as_object().unwrap().clone());
        let tree = json!({"nodes": [node], "output": {"node": 0, "output": "BSDF"}});
        let mut w = Vec::new();
        compile(&tree, 0, &mut w)
            .unwrap()
            .eval(&ShadingInputs::default(), &[], 0.5)
    };
    let c = hair(json!({"model": "CHIANG", "parametrization": "MELANIN"}));
    // Melanin 0.8 is the concentration −ln 0.2, all pheomelanin at Redness 1; a white Tint
    // absorbs nothing; Random 1 scales the roughness by 1 + Random Roughness.
    let concentration = -(0.2f32.ln());
    match c.hair {
        Some(Hair::Chiang {
            sigma, roughness, ..
        }) => {
            let expected = concentration * Vec3::new(0.343, 0.733, 1.924);
            assert!((sigma - expected).abs().max_element() < 1e-4, "{sigma}");
            assert!((roughness - 0.6).abs() < 1e-6);
        }
        other => panic!("{other:?}"),
    }
    assert_eq!((c.transmission, c.base_color), (1.0, Vec3::ONE));
    // The Huang model is not evaluated: the node falls back with a warning.
    let tree = json!({"nodes": [{"name": "H", "type": "ShaderNodeBsdfHairPrincipled",
        "model": "HUANG"}], "output": {"node": 0, "output": "BSDF"}});
    let mut w = Vec::new();
    assert!(compile(&tree, 0, &mut w)
        .unwrap()
        .eval(&ShadingInputs::default(), &[], 0.5)
        .hair
        .is_none());
    assert!(!w.is_empty());
}

/// A scene whose every ray is blocked, and whose own object is a plane through the point with
/// normal +X.
struct Enclosed;

impl SceneRays for Enclosed {
    fn occluded(&self, _: Vec3, _: f32, _: bool) -> bool {
        true
    }
    fn local_hits(&self, o: Vec3, d: Vec3, length: f32, visit: &mut dyn FnMut(LocalHit)) {
        let t = -o.x / d.x;
        if t >= 0.0 && t <= length {
            visit(LocalHit {
                position: o + t * d,
                geometric_normal: Vec3::X,
                normal: Vec3::X,
            });
        }
    }
    fn geometric_normal(&self) -> Vec3 {
        Vec3::X
    }
}

#[test]
fn ambient_occlusion_and_bevel_trace_the_scene_they_are_given() {
    let tree = |node: Value, output: &str| {
        json!({"nodes": [
            node,
            {"name": "E", "type": "ShaderNodeEmission",
             "inputs": {"Color": {"node": 0, "output": output}, "Strength": 1.0}}
        ], "output": {"node": 1, "output": "Emission"}})
    };
    let ao = tree(
        json!({"name": "AO", "type": "ShaderNodeAmbientOcclusion", "samples": 8.0,
               "inside": false, "only_local": false,
               "inputs": {"Color": [0.5, 0.25, 1.0, 1.0], "Distance": 2.0}}),
        "Color",
    );
    let bevel = tree(
        json!({"name": "B", "type": "ShaderNodeBevel", "samples": 4.0,
               "inputs": {"Radius": 0.1}}),
        "Normal",
    );
    let mut w = Vec::new();
    let ao = compile(&ao, 0, &mut w).expect("compiles");
    let bevel = compile(&bevel, 0, &mut w).expect("compiles");
    assert!(w.is_empty(), "{w:?}");
    assert!(ao.varies() && bevel.varies());
    let at = at_positions([Vec3::ZERO; 3], Vec3::Z);
    let tracing = Tracing {
        scene: &Enclosed,
        seed: 1,
    };
    // Without a scene: AO 1 (the colour itself) and the shading normal.
    assert_eq!(ao.eval(&at, &[], 0.5).emission, Vec3::new(0.5, 0.25, 1.0));
    assert_eq!(bevel.eval(&at, &[], 0.5).emission, Vec3::Z);
    // Enclosed: black; the bevel finds only the plane of normal +X.
    let traced = |p: &NodeProgram| p.eval_tracing(&at, &[], 0.5, Some(&tracing)).emission;
    assert_eq!(traced(&ao), Vec3::ZERO);
    assert!((traced(&bevel) - Vec3::X).length() < 1e-6);
}
