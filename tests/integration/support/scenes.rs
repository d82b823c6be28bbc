//! Small scenes built in code for the renderer's tests: analytic configurations whose answer is
//! known exactly.

use photon::film::Image;
use photon::math::{Affine3A, Vec2, Vec3};
use photon::medium::Coefficients;
use photon::progress::{Progress, ProgressEvent};
use photon::render::{render, RenderSettings, RenderStats};
use photon::scene::{
    Background, Camera, Light, Material, Mesh, Projection, Scene, SceneRenderSettings, Volume,
    World,
};
use photon::shader::{compile, CompileWarnings};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

/// Run `f` with a progress sink that is never cancelled and reports nothing.
pub fn with_progress<T>(f: impl FnOnce(&Progress) -> T) -> T {
    let cancel = AtomicBool::new(false);
    let report = |_: &ProgressEvent| {};
    f(&Progress {
        cancel: &cancel,
        report: &report,
    })
}

/// A mesh of `positions` with per-vertex `normals` and triangles `indices`, seen by the camera,
/// casting shadows, with no UVs, colours or motion.
pub fn mesh(
    name: &str,
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    indices: Vec<[u32; 3]>,
    material: u32,
) -> Mesh {
    Mesh {
        name: name.into(),
        positions,
        normals,
        uvs: Vec::new(),
        extra_uvs: Vec::new(),
        tangents: Vec::new(),
        indices,
        material,
        camera_visible: true,
        holdout: false,
        emission_spread: None,
        casts_shadows: true,
        colors: Vec::new(),
        object_space: None,
        deformation: Vec::new(),
        volume_grids: None,
        ..Mesh::default()
    }
}

/// A unit sphere tessellated by latitude/longitude, with normals pointing outward (or inward).
pub fn sphere(
    center: Vec3,
    radius: f32,
    rings: u32,
    segments: u32,
    inward: bool,
    material: u32,
) -> Mesh {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    for r in 0..=rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..=segments {
            let phi = std::f32::consts::TAU * s as f32 / segments as f32;
            let n = Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            );
            positions.push(center + radius * n);
            normals.push(if inward { -n } else { n });
        }
    }
    let mut indices = Vec::new();
    let row = segments + 1;
    for r in 0..rings {
        for s in 0..segments {
            let a = r * row + s;
            let b = a + row;
            // Counter-clockwise seen from outside.
            let (t1, t2) = ([a, a + 1, b], [a + 1, b + 1, b]);
            if inward {
                indices.push([t1[0], t1[2], t1[1]]);
                indices.push([t2[0], t2[2], t2[1]]);
            } else {
                indices.push(t1);
                indices.push(t2);
            }
        }
    }
    mesh("sphere", positions, normals, indices, material)
}

/// A square of side `size` in the plane y = `height`, facing +Y.
pub fn floor(size: f32, height: f32, material: u32) -> Mesh {
    let h = 0.5 * size;
    mesh(
        "floor",
        vec![
            Vec3::new(-h, height, -h),
            Vec3::new(-h, height, h),
            Vec3::new(h, height, h),
            Vec3::new(h, height, -h),
        ],
        vec![Vec3::Y; 4],
        vec![[0, 1, 2], [0, 2, 3]],
        material,
    )
}

/// A camera at `eye` looking at `target`, +Y up.
pub fn camera_looking_at(eye: Vec3, target: Vec3, projection: Projection) -> Camera {
    let up = if (target - eye).normalize().dot(Vec3::Y).abs() > 0.99 {
        Vec3::Z
    } else {
        Vec3::Y
    };
    let forward = (target - eye).normalize();
    let right = forward.cross(up).normalize();
    let true_up = right.cross(forward);
    Camera {
        name: "camera".into(),
        to_world: Affine3A::from_cols(right.into(), true_up.into(), (-forward).into(), eye.into()),
        projection,
        aspect_ratio: None,
        shift: Vec2::ZERO,
        lens: None,
        motion: Vec::new(),
        near_clip: 0.0,
        far_clip: f32::INFINITY,
    }
}

pub fn scene(
    meshes: Vec<Mesh>,
    materials: Vec<Material>,
    lights: Vec<Light>,
    camera: Camera,
    world: Vec3,
) -> Scene {
    Scene {
        prototypes: Vec::new(),
        instances: Vec::new(),
        meshes,
        materials,
        textures: Vec::new(),
        lights,
        camera,
        world: World {
            background: Background {
                color: world,
                environment: None,
            },
            camera_background: None,
            volume: None,
        },
        render_settings: SceneRenderSettings::default(),
        warnings: Vec::new(),
        export_notes: Vec::new(),
        light_links: Vec::new(),
    }
}

/// Inside a closed sphere whose surface has albedo ρ and emits Le, the radiance is Le / (1 − ρ)
/// everywhere. Here ρ = 0.5 and Le = 0.5, so every pixel converges to 1.
pub fn furnace() -> Scene {
    furnace_with_albedo(0.5)
}

/// The closed furnace sphere with albedo `albedo` and emission 1 − `albedo`: its radiance is 1
/// everywhere, a share `albedo`ⁿ of it from light that bounced more than n times.
pub fn furnace_with_albedo(albedo: f32) -> Scene {
    let mut m = Material::diffuse("furnace", Vec3::splat(albedo));
    m.emission = Vec3::splat(1.0 - albedo);
    scene(
        vec![sphere(Vec3::ZERO, 1.0, 32, 64, true, 0)],
        vec![m],
        Vec::new(),
        camera_looking_at(
            Vec3::new(0.0, 0.0, 0.3),
            Vec3::new(0.0, 0.0, -1.0),
            Projection::Perspective { yfov: 1.2 },
        ),
        Vec3::ZERO,
    )
}

/// A diffuse floor of albedo `albedo` lit only by `light`, seen from straight above by an
/// orthographic camera covering the central 0.2 × 0.2 of a 20 × 20 floor.
pub fn lit_floor(albedo: f32, light: Light) -> Scene {
    scene(
        vec![floor(20.0, 0.0, 0)],
        vec![Material::diffuse("floor", Vec3::splat(albedo))],
        vec![light],
        camera_looking_at(
            Vec3::new(0.0, 5.0, 0.0),
            Vec3::ZERO,
            Projection::Orthographic {
                xmag: 0.1,
                ymag: 0.1,
            },
        ),
        Vec3::ZERO,
    )
}

/// A closed sphere of albedo ρ = 0.5 whose top cap (y > 0.8 R) also emits Le = 10 inwards.
/// Inside a sphere every surface element receives the same irradiance from any other, so each
/// bounce spreads light uniformly: E = Φ / (4πR²) / (1 − ρ) with Φ = π·Le·A_cap, and every
/// non-emitting point shows L = ρE/π. Returns the scene and that radiance.
pub fn sphere_with_emissive_cap() -> (Scene, f32) {
    let mut whole = sphere(Vec3::ZERO, 1.0, 48, 96, true, 0);
    let mut cap = Mesh {
        name: "cap".into(),
        material: 1,
        indices: Vec::new(),
        ..whole.clone()
    };
    let mut rest = Vec::new();
    let mut cap_area = 0.0f32;
    for t in &whole.indices {
        let p = t.map(|i| whole.positions[i as usize]);
        if (p[0].y + p[1].y + p[2].y) / 3.0 > 0.8 {
            cap.indices.push(*t);
            cap_area += 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
        } else {
            rest.push(*t);
        }
    }
    whole.indices = rest;
    let albedo = 0.5;
    let le = 10.0;
    let mut emitter = Material::diffuse("cap", Vec3::splat(albedo));
    emitter.emission = Vec3::splat(le);
    emitter.double_sided = false;
    // The tessellated sphere's area, for the uniform-irradiance formula.
    let total_area: f32 = whole
        .indices
        .iter()
        .chain(&cap.indices)
        .map(|t| {
            let p = t.map(|i| whole.positions[i as usize]);
            0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length()
        })
        .sum();
    let flux = std::f32::consts::PI * le * cap_area;
    let irradiance = flux / total_area / (1.0 - albedo);
    let radiance = albedo * irradiance / std::f32::consts::PI;
    let scene = scene(
        vec![whole, cap],
        vec![Material::diffuse("wall", Vec3::splat(albedo)), emitter],
        Vec::new(),
        camera_looking_at(
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, -1.0, 0.2),
            Projection::Perspective { yfov: 1.0 },
        ),
        Vec3::ZERO,
    );
    (scene, radiance)
}

/// Scale the whole scene by `s` and move it by `offset` (camera and lights included; point and
/// spot intensities scale by s² so that the image stays the same).
pub fn transformed(mut scene: Scene, s: f32, offset: Vec3) -> Scene {
    for m in &mut scene.meshes {
        for p in &mut m.positions {
            *p = *p * s + offset;
        }
    }
    for light in &mut scene.lights {
        match light {
            Light::Point {
                position,
                intensity,
                radius,
                ..
            }
            | Light::Spot {
                position,
                intensity,
                radius,
                ..
            } => {
                *position = *position * s + offset;
                *intensity *= s * s;
                *radius *= s;
            }
            Light::Sun { .. } => {}
        }
    }
    let t = &mut scene.camera.to_world;
    t.translation = (Vec3::from(t.translation) * s + offset).into();
    if let Projection::Orthographic { xmag, ymag } = scene.camera.projection {
        scene.camera.projection = Projection::Orthographic {
            xmag: xmag * s,
            ymag: ymag * s,
        };
    }
    scene
}

/// A 48 × 32 render at 16 samples per pixel, the size the compressed-file tests compare.
pub fn render_small(scene: &Scene) -> Vec<[f32; 4]> {
    let settings = RenderSettings {
        width: 48,
        height: 32,
        spp: 16,
        ..RenderSettings::default()
    };
    render_quietly(scene, &settings).unwrap().0.rgba
}

/// Render with no progress output and no cancellation.
pub fn render_quietly(
    scene: &Scene,
    settings: &RenderSettings,
) -> photon::error::Result<(Image, RenderStats)> {
    with_progress(|progress| render(scene, settings, progress))
}

/// A material whose surface lets every ray through (a white Transparent BSDF, as a Blender
/// material with only a Volume) and whose inside is the homogeneous medium `c`.
pub fn volume_material(c: Coefficients) -> Material {
    let tree = serde_json::json!({
        "nodes": [{"name": "T", "type": "ShaderNodeBsdfTransparent",
                   "inputs": {"Color": [1, 1, 1, 1]}}],
        "output": {"node": 0, "output": "BSDF"}
    });
    let mut warnings = CompileWarnings::new();
    let program = compile(&tree, 0, &mut warnings).expect("transparent tree");
    Material {
        nodes: Some(Arc::new(program)),
        volume: Some(Volume::homogeneous(c)),
        ..Material::diffuse("volume", Vec3::ONE)
    }
}
