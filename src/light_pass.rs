//! The light-path passes (Blender's render passes Emit, DiffDir, DiffInd, VolumeDir, VolumeInd,
//! and Photon's Caustic and Subsurface): how the radiance of one camera sample splits by the path
//! the light took. In Photon "pass" means only this.

use crate::math::Vec3;

/// The light-path passes, classified by the non-specular scattering vertices ("D" in Heckbert's
/// notation, any non-delta lobe or a scattering in a medium) between the camera and the light,
/// and by the kind of the first of them (as Cycles' passes: the first scattering of a camera
/// path decides between its surface and its volume passes; delta lobes, which Photon does not
/// count as vertices, do not decide):
/// - `Emission`: none (E S* L: emitters seen directly or through delta lobes only, and the
///   emission of media along such paths);
/// - `Direct`: exactly one, on a surface (E S* D S* L);
/// - `Indirect`: two or more, the first on a surface; for the photon method also final
///   gathering, the irradiance cache and the global map's estimate;
/// - `Caustic`: the photon method's caustic-map estimate (L S+ D E). The path tracer leaves it 0:
///   its caustic paths are in `Direct` (one D vertex) or `Indirect` by the rule above;
/// - `Subsurface`: light that entered a translucent material (the photon method's dipole term;
///   everything after the path tracer's subsurface branch);
/// - `VolumeDirect`: exactly one, a scattering in a medium (light a medium scatters straight
///   from a light towards the camera);
/// - `VolumeIndirect`: two or more, the first in a medium; for the photon method also the
///   volume photon map's estimate along the camera path.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightPass {
    Emission,
    Direct,
    Indirect,
    Caustic,
    Subsurface,
    VolumeDirect,
    VolumeIndirect,
}

/// Where the first non-specular vertex of a camera path lies: it chooses between the surface
/// passes (`Direct`, `Indirect`) and the volume ones (`VolumeDirect`, `VolumeIndirect`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FirstVertex {
    Surface,
    Medium,
}

impl LightPass {
    pub const ALL: [LightPass; 7] = [
        LightPass::Emission,
        LightPass::Direct,
        LightPass::Indirect,
        LightPass::Caustic,
        LightPass::Subsurface,
        LightPass::VolumeDirect,
        LightPass::VolumeIndirect,
    ];

    /// The Emission / Direct / Indirect pass of light that met `diffuse` non-specular vertices,
    /// the first on a surface.
    pub fn after(diffuse: u32) -> LightPass {
        LightPass::after_first(diffuse, FirstVertex::Surface)
    }

    /// The pass of light that met `diffuse` non-specular vertices, the first of them at `first`:
    /// Emission, or the direct or indirect pass of a surface or a medium.
    pub fn after_first(diffuse: u32, first: FirstVertex) -> LightPass {
        match (diffuse, first) {
            (0, _) => LightPass::Emission,
            (1, FirstVertex::Surface) => LightPass::Direct,
            (_, FirstVertex::Surface) => LightPass::Indirect,
            (1, FirstVertex::Medium) => LightPass::VolumeDirect,
            (_, FirstVertex::Medium) => LightPass::VolumeIndirect,
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
pub struct Passes(pub [Vec3; 7]);

impl Passes {
    pub fn add(&mut self, pass: LightPass, v: Vec3) {
        self.0[pass as usize] += v;
    }

    /// Add `other` × `beta`, an estimate made at a surface vertex whose Emission, Direct and
    /// Indirect light counts from that vertex, moving that light `diffuse` non-specular vertices
    /// further from the camera (`LightPass::after_first`, the first of them at `first` when
    /// `diffuse` > 0).
    pub fn add_after(&mut self, other: &Passes, beta: Vec3, diffuse: u32, first: FirstVertex) {
        let first = if diffuse == 0 {
            FirstVertex::Surface
        } else {
            first
        };
        for (i, &v) in other.0.iter().enumerate() {
            let pass = match LightPass::ALL[i] {
                LightPass::Emission => LightPass::after_first(diffuse, first),
                LightPass::Direct => LightPass::after_first(diffuse + 1, first),
                LightPass::Indirect => LightPass::after_first(2, first),
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_vertex_chooses_surface_or_volume_passes() {
        use FirstVertex::{Medium, Surface};
        assert_eq!(LightPass::after_first(0, Medium), LightPass::Emission);
        assert_eq!(LightPass::after_first(1, Medium), LightPass::VolumeDirect);
        assert_eq!(LightPass::after_first(3, Medium), LightPass::VolumeIndirect);
        assert_eq!(LightPass::after_first(1, Surface), LightPass::Direct);
        assert_eq!(LightPass::after(2), LightPass::Indirect);
    }

    #[test]
    fn an_estimate_moves_behind_the_vertices_before_it() {
        let mut estimate = Passes::default();
        estimate.add(LightPass::Emission, Vec3::splat(1.0));
        estimate.add(LightPass::Direct, Vec3::splat(2.0));
        estimate.add(LightPass::Indirect, Vec3::splat(4.0));
        estimate.add(LightPass::VolumeIndirect, Vec3::splat(8.0));
        let beta = Vec3::splat(0.5);
        // Seen straight from the camera: unchanged.
        let mut at_camera = Passes::default();
        at_camera.add_after(&estimate, beta, 0, FirstVertex::Medium);
        assert_eq!(at_camera.0[LightPass::Emission as usize], Vec3::splat(0.5));
        assert_eq!(at_camera.0[LightPass::Direct as usize], Vec3::splat(1.0));
        // Behind a scattering in a medium: all of it volume light.
        let mut behind = Passes::default();
        behind.add_after(&estimate, beta, 1, FirstVertex::Medium);
        assert_eq!(behind.0[LightPass::VolumeDirect as usize], Vec3::splat(0.5));
        assert_eq!(
            behind.0[LightPass::VolumeIndirect as usize],
            Vec3::splat(7.0)
        );
        assert_eq!(behind.total(), Vec3::splat(7.5));
    }
}
