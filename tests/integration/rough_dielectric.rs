//! The photon method on dielectrics against the path tracer: a rough glass
//! slab over a floor under a grey world, and a diffuse floor sealed inside a smooth glass box.
//!
//! Before the fix the photon method rendered the rough slab +9 % too bright (a Blender Glass
//! slab; +2.5 % for a Refraction BSDF) and the sealed floor about η² too bright: photons
//! scattered by the camera paths' BSDF, which conserves radiance across an interface, where
//! they must scatter by its adjoint (their flux inside a medium of index η is 1/η² of what
//! crossed, `tracing::adjoint_scale`). Rough dielectrics are now ray traced by the camera paths
//! and final gathering (`classify::stores_photons`) instead of estimated from photons there:
//! the same mean as the path tracer, and the path tracer's noise.

use crate::support::scenes;

use photon::film::Image;
use photon::integrator::photon::settings::PhotonSettings;
use photon::math::{Quat, Vec3};
use photon::metrics::{compare, ImageError};
use photon::render::{render, Method, RenderSettings};
use photon::scene::{Camera, Material, Mesh, Projection, Scene};
use scenes::{camera_looking_at, floor, scene, with_progress};

/// A box of half-extents `half` centred at `center`, turned by `turn` radians about +Y, with
/// outward normals and counter-clockwise winding seen from outside (flat faces).
fn box_mesh(center: Vec3, half: Vec3, turn: f32, material: u32) -> Mesh {
    let rotation = Quat::from_rotation_y(turn);
    let mut mesh = floor(1.0, 0.0, material);
    mesh.name = "box".into();
    mesh.positions.clear();
    mesh.normals.clear();
    mesh.indices.clear();
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let mut n = Vec3::ZERO;
            n[axis] = sign;
            // Two tangents of the face.
            let u = match axis {
                0 => Vec3::Y,
                1 => Vec3::Z,
                _ => Vec3::X,
            };
            let v = n.cross(u);
            let base = mesh.positions.len() as u32;
            for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                let local = (n + u * a + v * b) * half;
                mesh.positions.push(center + rotation * local);
                mesh.normals.push(rotation * n);
            }
            // Wind the quad so that it faces n.
            let (p0, p1, p2) = (
                mesh.positions[base as usize],
                mesh.positions[base as usize + 1],
                mesh.positions[base as usize + 2],
            );
            if (p1 - p0).cross(p2 - p0).dot(rotation * n) > 0.0 {
                mesh.indices
                    .extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
            } else {
                mesh.indices
                    .extend([[base, base + 2, base + 1], [base, base + 3, base + 2]]);
            }
        }
    }
    mesh
}

/// A tinted glass material (Principled, transmission 1) of `roughness` and IOR 1.45.
fn glass(roughness: f32) -> Material {
    Material {
        name: format!("glass {roughness}"),
        base_color: Vec3::new(0.9, 0.75, 0.5).extend(1.0),
        metallic: 0.0,
        roughness,
        transmission: 1.0,
        ior: 1.45,
        ..Material::default()
    }
}

/// The camera both scenes use: above the floor, looking down at the box.
fn over_the_floor() -> Camera {
    camera_looking_at(
        Vec3::new(0.3, 3.0, 0.5),
        Vec3::new(0.0, 0.3, 0.0),
        Projection::Perspective { yfov: 0.6 },
    )
}

/// A grey floor with a box of `box_material` on or above it, seen from above, lit by a grey
/// world of radiance 0.8.
fn box_over_a_floor(box_material: Material, center: Vec3, half: Vec3, turn: f32) -> Scene {
    scene(
        vec![floor(6.0, 0.0, 0), box_mesh(center, half, turn, 1)],
        vec![Material::diffuse("floor", Vec3::splat(0.6)), box_material],
        Vec::new(),
        over_the_floor(),
        Vec3::splat(0.8),
    )
}

fn rendered(scene: &Scene, method: Method, spp: u32) -> (Image, f64) {
    let settings = RenderSettings {
        width: 24,
        height: 24,
        spp,
        max_depth: 32,
        seed: 1,
        method,
        photon: PhotonSettings {
            global_photons: 50_000,
            caustic_photons: 50_000,
            ..PhotonSettings::default()
        },
        ..RenderSettings::default()
    };
    let start = std::time::Instant::now();
    let (image, stats) = with_progress(|p| render(scene, &settings, p)).expect("render");
    assert_eq!(stats.nonfinite_samples, 0);
    (image, start.elapsed().as_secs_f64())
}

/// The photon method's image of `scene` against the path tracer's (both at `spp`).
fn photon_against_path(scene: &Scene, spp: u32) -> (ImageError, f64, f64) {
    let (path, path_time) = rendered(scene, Method::Path, spp);
    let (photon, photon_time) = rendered(scene, Method::Photon, spp);
    (compare(&photon.rgba, &path.rgba), photon_time, path_time)
}

#[test]
fn a_rough_glass_slab_renders_as_the_path_tracer_renders_it() {
    // The slab of tests/blender/test_nodes_refraction.py (Principled glass here): 1.1 m
    // square, 0.35 m thick, 0.45 m above the floor, turned 25°, roughness 0.3. Measured (24 px,
    // 256 spp, 50 000 photons per map): before the fix photon +3.7 %, relMSE 0.024; after it
    // +0.15 %, relMSE 0.0014.
    let scene = box_over_a_floor(
        glass(0.3),
        Vec3::new(0.0, 0.45, 0.0),
        Vec3::new(0.55, 0.175, 0.55),
        25f32.to_radians(),
    );
    let (e, photon_time, path_time) = photon_against_path(&scene, 256);
    eprintln!("rough slab: photon against path {e:?}, {photon_time:.1} s vs {path_time:.1} s");
    assert!(e.mean_relative_difference.abs() < 0.015, "{e:?}");
    assert!(e.rel_mse < 0.005, "{e:?}");
}

#[test]
fn a_floor_sealed_in_smooth_glass_renders_as_the_path_tracer_renders_it() {
    // A diffuse floor inside a closed smooth glass box: every photon stored on it crossed into
    // the glass. Measured (24 px, 256 spp): before the fix photon +25.4 % (the floor seen
    // through the glass about η² = 2.1× too bright), after it −2.2 %, relMSE 0.004 (a
    // residual not looked into yet: more caustic photons do not move it).
    let mut inside = scene(
        vec![
            floor(6.0, 0.0, 0),
            box_mesh(Vec3::new(0.0, 0.35, 0.0), Vec3::new(0.6, 0.3, 0.6), 0.3, 1),
            floor(0.9, 0.15, 0),
        ],
        vec![Material::diffuse("floor", Vec3::splat(0.6)), glass(0.0)],
        Vec::new(),
        over_the_floor(),
        Vec3::splat(0.8),
    );
    inside.materials[1].base_color = Vec3::ONE.extend(1.0);
    let (e, photon_time, path_time) = photon_against_path(&inside, 256);
    eprintln!("sealed floor: photon against path {e:?}, {photon_time:.1} s vs {path_time:.1} s");
    assert!(e.mean_relative_difference.abs() < 0.05, "{e:?}");
}
