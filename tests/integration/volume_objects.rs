//! Volume objects (voxel grids in an object's space) against Beer–Lambert: their density is
//! per unit of the object's own length, as Blender's default volume space ("Object") has it,
//! so a Volume object scaled down is as opaque as before, and ratio tracking
//! (`medium::transmittance`) through it, against the object's majorant grid, agrees with the
//! optical depth integrated finely from `Volume::at`.

use crate::support::scenes::{camera_looking_at, scene, sphere, volume_material};

use photon::math::{Affine3A, Mat3, Mat4, Vec3};
use photon::medium::{transmittance, Coefficients, Media};
use photon::rng::Rng;
use photon::scene::grids::{Grid, VolumeGrids};
use photon::scene::{ObjectSpace, Projection, Scene, Volume, BLENDER_AXES};
use photon::shader::{compile, CompileWarnings};
use std::sync::Arc;

/// The medium inside mesh 0 of a scene, as a ray inside it reads it.
struct Inside<'a>(&'a Scene);

impl Media for Inside<'_> {
    fn at(&self, p: Vec3, _u: f32) -> Coefficients {
        self.volume().at(self.0, Some((0, u32::MAX)), p, 0.5)
    }
    fn homogeneous(&self) -> Option<Coefficients> {
        None
    }
    fn majorant(&self) -> f32 {
        self.volume().majorant
    }
    fn majorant_along(&self, origin: Vec3, dir: Vec3, t: f32) -> (f32, f32) {
        self.volume()
            .majorant_along(self.0, Some((0, u32::MAX)), origin, dir, t)
    }
}

impl Inside<'_> {
    fn volume(&self) -> &Volume {
        self.0.materials[0].volume.as_ref().unwrap()
    }
}

/// A unit sphere holding a Volume object scaled by `scale` about the origin: a "density"
/// grid of a soft ball (1 − r/1.6 in object units, Principled Volume of Density 2, black) over
/// 9³ voxels spanning the object's [−2, 2]³; its density per unit of world length with
/// `world_space` (Blender's volume space "World").
fn scaled_smoke(scale: f32, world_space: bool) -> Scene {
    let tree = serde_json::json!({
        "nodes": [{"name": "P", "type": "ShaderNodeVolumePrincipled",
                   "attributes": {"density": "density", "color": "", "temperature": ""},
                   "inputs": {"Color": [0, 0, 0, 1], "Density": 2.0}}],
        "output": {"node": 0, "output": "Volume"}
    });
    let program = compile(&tree, 0, &mut CompileWarnings::new()).expect("volume tree");
    let n = 9;
    let spacing = 0.5;
    let first = -0.5 * spacing * (n - 1) as f32;
    let to_object =
        Mat4::from_translation(Vec3::splat(first)) * Mat4::from_scale(Vec3::splat(spacing));
    let values = (0..n * n * n)
        .map(|i| {
            let v = Vec3::new((i % n) as f32, ((i / n) % n) as f32, (i / (n * n)) as f32);
            let r = (Vec3::splat(first) + spacing * v).length();
            (1.0 - r / 1.6).max(0.0)
        })
        .collect();
    let grid = Grid::new("density".into(), 1, [n, n, n], values, to_object).unwrap();
    let mut s = scene(
        vec![sphere(Vec3::ZERO, 1.0, 48, 96, false, 0)],
        vec![volume_material(Coefficients::VACUUM)],
        Vec::new(),
        camera_looking_at(
            Vec3::new(0.0, 0.0, 4.0),
            Vec3::ZERO,
            Projection::Orthographic {
                xmag: 1.0,
                ymag: 1.0,
            },
        ),
        Vec3::ONE,
    );
    s.materials[0].volume = Volume::of(program);
    s.meshes[0].volume_grids = Some(Arc::new(VolumeGrids {
        grids: vec![grid],
        majorant: None,
        world_space,
        extent: None,
        stochastic: false,
    }));
    s.meshes[0].object_space = Some(ObjectSpace {
        to_object: Affine3A::from_mat3(
            Mat3::from_diagonal(Vec3::splat(1.0 / scale)) * BLENDER_AXES,
        ),
        texspace_location: Vec3::ZERO,
        texspace_size: Vec3::ONE,
    });
    s.bound_volumes();
    s
}

/// The optical depth along `length` from `origin` along `dir`, by the midpoint rule.
fn optical_depth(media: &Inside, origin: Vec3, dir: Vec3, length: f32) -> f32 {
    let steps = 4000;
    let dt = length / steps as f32;
    (0..steps)
        .map(|i| {
            media
                .at(origin + (i as f32 + 0.5) * dt * dir, 0.0)
                .extinction()
                .x
                * dt
        })
        .sum()
}

#[test]
fn volume_objects_keep_their_opacity_at_any_scale() {
    let full = scaled_smoke(1.0, false);
    let half = scaled_smoke(0.5, false);
    let (full, half) = (Inside(&full), Inside(&half));
    // Through the centre: the half-size object is twice as dense over half the length.
    let whole = optical_depth(&full, Vec3::new(0.0, 0.0, -2.0), Vec3::Z, 4.0);
    let scaled = optical_depth(&half, Vec3::new(0.0, 0.0, -1.0), Vec3::Z, 2.0);
    assert!(whole > 1.0, "the ball absorbs: {whole}");
    assert!(
        (scaled - whole).abs() < 1e-3 * whole,
        "optical depth {scaled} at half scale vs {whole}"
    );
}

#[test]
fn world_space_volume_objects_keep_their_density_per_world_unit() {
    let full = scaled_smoke(1.0, true);
    let half = scaled_smoke(0.5, true);
    let (full, half) = (Inside(&full), Inside(&half));
    // Through the centre: as dense as before over half the length.
    let whole = optical_depth(&full, Vec3::new(0.0, 0.0, -2.0), Vec3::Z, 4.0);
    let scaled = optical_depth(&half, Vec3::new(0.0, 0.0, -1.0), Vec3::Z, 2.0);
    assert!(
        (scaled - 0.5 * whole).abs() < 1e-3 * whole,
        "optical depth {scaled} at half scale vs {whole} at full"
    );
    // The majorant grid still bounds it.
    let mut rng = Rng::new(5);
    let dir = Vec3::new(0.2, 0.1, 1.0).normalize();
    let origin = -1.2 * dir;
    let exact = (-optical_depth(&half, origin, dir, 2.4)).exp();
    let n = 40_000;
    let tracked = (0..n)
        .map(|_| transmittance(&half, origin, dir, 2.4, &mut rng).x as f64)
        .sum::<f64>()
        / n as f64;
    assert!(
        (tracked as f32 - exact).abs() < 0.015 * exact + 2e-3,
        "ratio tracking {tracked} vs Beer–Lambert {exact}"
    );
}

#[test]
fn volume_objects_track_their_scaled_density() {
    let s = scaled_smoke(0.6, false);
    let media = Inside(&s);
    let mut rng = Rng::new(11);
    for ray in 0..6 {
        let dir = Vec3::new(0.3 * ray as f32 - 0.7, 0.4, 1.0).normalize();
        let offset = Vec3::new(0.05 * ray as f32, -0.1, 0.0);
        let origin = offset - 1.5 * dir;
        let exact = (-optical_depth(&media, origin, dir, 3.0)).exp();
        let n = 40_000;
        let tracked = (0..n)
            .map(|_| transmittance(&media, origin, dir, 3.0, &mut rng).x as f64)
            .sum::<f64>()
            / n as f64;
        assert!(exact < 0.6, "ray {ray} crosses the smoke: {exact}");
        assert!(
            (tracked as f32 - exact).abs() < 0.015 * exact + 2e-3,
            "ray {ray}: ratio tracking {tracked} vs Beer–Lambert {exact}"
        );
    }
}
