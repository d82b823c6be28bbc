//! Material evaluation at a surface point: textures and factors resolved into the small plain
//! `SurfaceMaterial` that shading reads (yocto-gl's `eval_material` habit).
//!
//! CONTRACT (filled in by the BSDF work): `eval_material` multiplies every glTF factor by its
//! texture as the glTF spec says (base colour × texture, metallic = B channel, roughness = G
//! channel, emission × emissive texture, transmission × R channel of its texture).

use crate::math::{Vec2, Vec3};
use crate::scene::{Material, Scene};

/// A material's values at one point, with textures applied. Colours are linear RGB.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceMaterial {
    pub base_color: Vec3,
    /// Coverage in [0, 1] (base colour alpha × texture alpha).
    pub alpha: f32,
    pub metallic: f32,
    /// Perceptual roughness in [0, 1].
    pub roughness: f32,
    pub transmission: f32,
    pub ior: f32,
    pub specular: f32,
    pub specular_color: Vec3,
    /// Emitted radiance (W·m⁻²·sr⁻¹).
    pub emission: Vec3,
    /// Beer–Lambert absorption coefficient σ_a per channel (per scene unit) inside the object;
    /// zero when the material has no volume.
    pub absorption: Vec3,
    pub thin_walled: bool,
}

/// Resolve `material` at texture coordinate `uv`.
pub fn eval_material(scene: &Scene, material: &Material, uv: Vec2) -> SurfaceMaterial {
    let _ = (scene, uv);
    SurfaceMaterial {
        base_color: material.base_color.truncate(),
        alpha: material.base_color.w,
        metallic: material.metallic,
        roughness: material.roughness,
        transmission: material.transmission,
        ior: material.ior,
        specular: material.specular,
        specular_color: material.specular_color,
        emission: material.emission,
        absorption: Vec3::ZERO,
        thin_walled: material.thickness <= 0.0,
    }
}
