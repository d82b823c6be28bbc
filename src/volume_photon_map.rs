//! The volume photon map of Jensen & Christensen (1998, "Efficient simulation of light transport
//! in scenes with participating media using photon maps"): photons stored where they scatter in
//! a participating medium, with their position, the direction they came from and their power,
//! balanced into a kd-tree (`crate::photon_map`), and read along camera and final-gather rays
//! by the beam radiance estimate of Jarosz, Zwicker & Jensen (2008, "The beam radiance estimate
//! for volumetric photon mapping").
//!
//! A photon's power Φ is its flux times σ_s where it scattered (what a free flight weighs it
//! by), so the in-scattered radiance σ_s ∫ p L_i dω at a point is the density of Σ p·Φ and
//! σ_s never needs to be read back. The radiance the map adds along a ray over a segment is
//! then ∫ T(t) Σ p(θ_i) Φ_i K(x(t) − x_i) dt; with each photon blurred over a sphere of radius
//! r and the sphere's integral along the ray taken as a disc facing it, every photon whose disc
//! the segment crosses adds T(t_i)·p(θ_i)·Φ_i/(πr²), t_i its projection on the ray. One search
//! along the whole segment replaces the many fixed-step searches of Jensen & Christensen's ray
//! marching: no step length to choose and no photon counted twice or missed between steps.
//! The radius is the same for every photon and shrinks with the render's generations, as the
//! surface maps' radii do, so the estimate is consistent (Knaus & Zwicker 2011).

use crate::math::Vec3;
use crate::photon_map::{Photon, PhotonMap};
use std::f32::consts::PI;

/// Photons that scattered in media, and the radius of the disc each one stands for.
pub struct VolumePhotonMap {
    map: PhotonMap,
    radius: f32,
}

impl VolumePhotonMap {
    /// The map of `photons` (positions where they scattered, `Photon::incoming` towards where
    /// they came from) read with discs of radius `radius`; `None` without photons.
    pub fn new(photons: Vec<Photon>, radius: f32) -> Option<VolumePhotonMap> {
        (!photons.is_empty() && radius > 0.0).then(|| VolumePhotonMap {
            map: PhotonMap::build(photons),
            radius,
        })
    }

    pub fn len(&self) -> usize {
        self.map.len()
    }

    pub fn is_empty(&self) -> bool {
        self.map.is_empty()
    }

    pub fn radius(&self) -> f32 {
        self.radius
    }

    /// The beam radiance estimate over the segment from `origin` along unit `dir` over
    /// [0, `length`]: Σ `weight(t, photon)`·Φ/(πr²) over the photons whose disc the segment
    /// crosses, `weight` giving the transmittance to the photon's projection `t` times its
    /// phase function towards the ray's origin.
    pub fn beam(
        &self,
        origin: Vec3,
        dir: Vec3,
        length: f32,
        mut weight: impl FnMut(f32, &Photon) -> Vec3,
    ) -> Vec3 {
        let mut sum = Vec3::ZERO;
        self.map
            .along_segment(origin, dir, length, self.radius, |photon, t, _| {
                sum += weight(t, photon) * photon.power();
            });
        sum / (PI * self.radius * self.radius)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Photons spread uniformly through a slab of volume V with total power P: a ray crossing
    /// it over length ℓ with unit weights reads P·ℓ/V on average (the density of power
    /// integrated along the ray).
    #[test]
    fn uniform_photons_give_their_density_along_the_ray() {
        let mut rng = crate::rng::Rng::new(11);
        let n = 200_000;
        let (size, power) = (2.0f32, 3.0f32);
        let photons: Vec<Photon> = (0..n)
            .map(|_| {
                let p = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * size;
                Photon::new(p, Vec3::splat(power / n as f32), Vec3::Z, 1, false)
            })
            .collect();
        let map = VolumePhotonMap::new(photons, 0.1).expect("photons");
        let mut sum = 0.0;
        let rays = 400;
        for _ in 0..rays {
            let y = 0.2 + 1.6 * rng.uniform();
            let z = 0.2 + 1.6 * rng.uniform();
            let origin = Vec3::new(0.5, y, z);
            sum += map.beam(origin, Vec3::X, 1.0, |_, _| Vec3::ONE).x;
        }
        let got = sum / rays as f32;
        let want = power * 1.0 / (size * size * size);
        assert!((got - want).abs() < 0.03 * want, "{got} vs {want}");
    }
}
