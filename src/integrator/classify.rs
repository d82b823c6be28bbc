//! Which surfaces are which, for every integrator, photon tracing and the scene planner alike:
//! specular (ray traced, never estimated from photons), Lambertian (served by the irradiance
//! cache), and "stores photons" (Jensen's D in L(S|D)*E: shaded from the photon maps).
//!
//! "Specular" means a delta lobe, or a surface without a Lambertian part whose perceptual
//! roughness is below `SPECULAR_ROUGHNESS` (LuxCore's glossiness threshold): such lobes are
//! narrow enough that ray tracing them converges fast, while a photon estimate would blur them.
//! A dielectric without a Lambertian part (glass, a Refraction BSDF) is specular at any
//! roughness (`Bsdf::is_glossy_dielectric`): photons on both of its sides would have to be
//! estimated through its narrow refraction lobe, from the few of the k nearest that fall in
//! it, which is slow and noisy where ray tracing it, as the path tracer does, converges fast
//! (docs/bench/photon_method.md, "Photons inside glass"); light through it onto diffuse
//! surfaces is a caustic. A hair fibre counts as such a dielectric (`Bsdf::is_glossy_dielectric`):
//! a photon estimate on a strand would gather its neighbours' photons.

use crate::bsdf::{Bsdf, ViewedBsdf};
use crate::material::{eval_material, from_closure};
use crate::math::{max_component, Vec2, Vec3};
use crate::scene::Scene;
use crate::shader::ShadingInputs;

/// Perceptual roughness below which a surface without Lambertian part counts as specular.
pub const SPECULAR_ROUGHNESS: f32 = 0.049;

/// True when a photon arriving at this surface is stored and the renderer reads photon maps
/// here: some lobe is not a delta, and the surface is not a glossy-only one (no Lambertian part
/// and roughness below `SPECULAR_ROUGHNESS`) nor a dielectric without a Lambertian part.
pub fn stores_photons(bsdf: &ViewedBsdf) -> bool {
    bsdf.has_non_delta()
        && !bsdf.is_glossy_dielectric()
        && (bsdf.roughness() >= SPECULAR_ROUGHNESS || bsdf.diffuse_reflectance() != Vec3::ZERO)
}

/// True when the BSDF's whole albedo is its diffuse lobe's (within 1e-4): it scatters as a
/// Lambertian surface.
pub fn is_lambertian(bsdf: &ViewedBsdf) -> bool {
    bsdf.diffuse_is_lambertian() && max_component(bsdf.albedo() - bsdf.diffuse_reflectance()) < 1e-4
}

/// ρ of a Lambertian opaque BSDF (the surfaces the irradiance cache serves alone), `None` for
/// any other.
pub fn lambertian_reflectance(bsdf: &ViewedBsdf, opaque: bool) -> Option<Vec3> {
    let rho = bsdf.diffuse_reflectance();
    (opaque && rho != Vec3::ZERO && is_lambertian(bsdf)).then_some(rho)
}

/// ρ_d of the Lambertian diffuse lobe of an opaque BSDF (alone or under a glossy layer),
/// `None` when it has none (or an Oren–Nayar one, whose light is not ρ_d/π × E): the surfaces
/// that get irradiance-cache records.
pub fn diffuse_reflectance(bsdf: &ViewedBsdf, opaque: bool) -> Option<Vec3> {
    let rho = bsdf.diffuse_reflectance();
    (opaque && rho != Vec3::ZERO && bsdf.diffuse_is_lambertian()).then_some(rho)
}

/// The BSDF that classifies material `m` for photon tracing and the scene planner: its value at
/// texture coordinate 0, with roughness textures counted as smooth (a texture may reach 0).
pub fn classifying_bsdf(scene: &Scene, m: u32) -> Bsdf {
    let material = &scene.materials[m as usize];
    let mut s = match &material.nodes {
        // A node tree: its value at a default point (texture coordinates 0), with the first
        // closure of each Mix Shader.
        Some(program) => from_closure(
            material,
            &program.eval(&ShadingInputs::default(), &scene.textures, 0.0),
        ),
        None => eval_material(scene, material, Vec2::ZERO),
    };
    if material.metallic_roughness_texture.is_some() {
        s.roughness = 0.0;
    }
    Bsdf::new(&s)
}

/// True when `b` has a delta or glossy-only lobe, or is a dielectric without a Lambertian part
/// (module header): a photon may scatter specularly off it.
pub fn bsdf_is_specular(b: &Bsdf) -> bool {
    b.has_delta()
        || (b.has_specular() && b.roughness() < SPECULAR_ROUGHNESS)
        || (b.is_glossy_dielectric() && b.has_non_delta())
}

/// True when material `m` (classified by `classifying_bsdf`) scatters photons specularly.
pub fn is_specular(scene: &Scene, m: u32) -> bool {
    bsdf_is_specular(&classifying_bsdf(scene, m))
}
