//! The light-path passes (Blender's render passes Emit, DiffDir, DiffInd, and Photon's Caustic
//! and Subsurface): how the radiance of one camera sample splits by the path the light took. In
//! Photon "pass" means only this.

use crate::math::Vec3;

/// The light-path passes, classified by the non-specular scattering vertices ("D" in Heckbert's
/// notation, any non-delta lobe) between the camera and the light:
/// - `Emission`: none (E S* L: emitters seen directly or through delta lobes only);
/// - `Direct`: exactly one (E S* D S* L);
/// - `Indirect`: two or more; for the photon method also final gathering, the irradiance cache
///   and the global map's estimate;
/// - `Caustic`: the photon method's caustic-map estimate (L S+ D E). The path tracer leaves it 0:
///   its caustic paths are in `Direct` (one D vertex) or `Indirect` by the rule above;
/// - `Subsurface`: light that entered a translucent material (the photon method's dipole term;
///   everything after the path tracer's subsurface branch).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightPass {
    Emission,
    Direct,
    Indirect,
    Caustic,
    Subsurface,
}

impl LightPass {
    pub const ALL: [LightPass; 5] = [
        LightPass::Emission,
        LightPass::Direct,
        LightPass::Indirect,
        LightPass::Caustic,
        LightPass::Subsurface,
    ];

    /// The Emission / Direct / Indirect pass of light that met `diffuse` non-specular vertices.
    pub fn after(diffuse: u32) -> LightPass {
        match diffuse {
            0 => LightPass::Emission,
            1 => LightPass::Direct,
            _ => LightPass::Indirect,
        }
    }
}

impl std::ops::AddAssign for Passes {
    fn add_assign(&mut self, other: Passes) {
        for (a, b) in self.0.iter_mut().zip(other.0) {
            *a += b;
        }
    }
}

/// Radiance per `LightPass` (a fixed array: no allocation per sample).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Passes(pub [Vec3; 5]);

impl Passes {
    pub fn add(&mut self, pass: LightPass, v: Vec3) {
        self.0[pass as usize] += v;
    }

    /// Add `other` × `beta`, moving its Emission / Direct / Indirect light `diffuse` non-specular
    /// vertices further from the camera (`LightPass::after`).
    pub fn add_after(&mut self, other: &Passes, beta: Vec3, diffuse: u32) {
        for (i, &v) in other.0.iter().enumerate() {
            let pass = match LightPass::ALL[i] {
                LightPass::Emission => LightPass::after(diffuse),
                LightPass::Direct => LightPass::after(diffuse + 1),
                LightPass::Indirect => LightPass::Indirect,
                p => p,
            };
            self.add(pass, beta * v);
        }
    }

    /// Multiply every pass by `s`.
    pub fn scale(&mut self, s: f32) {
        self.0.iter_mut().for_each(|v| *v *= s);
    }

    pub fn total(&self) -> Vec3 {
        self.0.iter().fold(Vec3::ZERO, |s, &v| s + v)
    }
}
