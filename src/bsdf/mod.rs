//! The surface scattering model: Blender's Principled BSDF as glTF's metallic-roughness model
//! describes it. Closed set of lobes, static dispatch, free functions.
//!
//! Conventions (all functions):
//! - directions are in the local shading frame, normal = +Z, both `wo` and `wi` point away from
//!   the surface; `wo.z < 0` means the viewer is on the back side (inside, for transmissive
//!   materials);
//! - `eval_bsdf` returns f(wo, wi) · |cos θi| (the cosine is included);
//! - `sample_bsdf` returns `None` when it produces no direction; its `weight` is
//!   f · |cos θi| / pdf; for delta lobes `pdf` is the discrete probability of the lobe and
//!   `delta` is true;
//! - `bsdf_pdf` is the solid-angle density of `sample_bsdf` over the non-delta lobes.
//!
//! CONTRACT: this stub is a Lambertian; the BSDF work replaces it.

use crate::material::SurfaceMaterial;
use crate::math::{Vec2, Vec3};
use crate::sampling::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use std::f32::consts::FRAC_1_PI;

/// The BSDF at one point, built once per hit from a `SurfaceMaterial`.
#[derive(Clone, Copy, Debug)]
pub struct Bsdf {
    pub base_color: Vec3,
}

/// One sampled direction.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    /// f · |cos θi| / pdf.
    pub weight: Vec3,
    pub pdf: f32,
    /// A delta lobe (smooth mirror or glass): no light sampling, no MIS.
    pub delta: bool,
    /// `wi` is on the other side of the surface from `wo`.
    pub transmitted: bool,
}

impl Bsdf {
    pub fn new(m: &SurfaceMaterial) -> Self {
        Bsdf {
            base_color: m.base_color,
        }
    }

    /// True when some lobe is not a delta: light sampling can contribute.
    pub fn has_non_delta(&self) -> bool {
        true
    }
}

pub fn eval_bsdf(b: &Bsdf, wo: Vec3, wi: Vec3) -> Vec3 {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return Vec3::ZERO;
    }
    b.base_color * FRAC_1_PI * wi.z
}

pub fn sample_bsdf(b: &Bsdf, wo: Vec3, _u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
    if wo.z <= 0.0 {
        return None;
    }
    let wi = square_to_cosine_hemisphere(u);
    let pdf = cosine_hemisphere_pdf(wi.z);
    if pdf <= 0.0 {
        return None;
    }
    Some(BsdfSample {
        wi,
        weight: b.base_color,
        pdf,
        delta: false,
        transmitted: false,
    })
}

pub fn bsdf_pdf(_b: &Bsdf, wo: Vec3, wi: Vec3) -> f32 {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    cosine_hemisphere_pdf(wi.z)
}
