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
//! marching: no step length to choose, and each photon near the ray is met once instead of once
//! per step whose sphere holds it. Chosen by measurement (`beam_against_ray_marching`,
//! docs/bench/volumes.md): over the same photons and radius the beam estimate took less time
//! per ray than ray marching at a step of one radius, with a lower error, and shorter steps
//! only cost more time for little less error.
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

    /// `beam` with the photons visited in the order of their projections along the segment,
    /// nearest first (gathered and sorted in `buffer`), so that `weight` can carry the
    /// transmittance forward from one photon to the next instead of tracking it from the
    /// segment's start for each.
    pub fn beam_in_order(
        &self,
        origin: Vec3,
        dir: Vec3,
        length: f32,
        buffer: &mut Vec<(f32, Photon)>,
        mut weight: impl FnMut(f32, &Photon) -> Vec3,
    ) -> Vec3 {
        buffer.clear();
        self.map
            .along_segment(origin, dir, length, self.radius, |photon, t, _| {
                buffer.push((t, *photon));
            });
        buffer.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        let mut sum = Vec3::ZERO;
        for (t, photon) in buffer.iter() {
            sum += weight(*t, photon) * photon.power();
        }
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

    /// The ordered estimate meets the same photons as `beam`, nearest first.
    #[test]
    fn beam_in_order_visits_the_same_photons_nearest_first() {
        let mut rng = crate::rng::Rng::new(5);
        let photons: Vec<Photon> = (0..20_000)
            .map(|_| {
                let p = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 2.0;
                Photon::new(p, Vec3::splat(1e-3), Vec3::Z, 1, false)
            })
            .collect();
        let map = VolumePhotonMap::new(photons, 0.1).expect("photons");
        let (origin, dir) = (
            Vec3::new(0.1, 1.0, 0.9),
            Vec3::new(1.0, 0.2, 0.1).normalize(),
        );
        let weight = |t: f32, _: &Photon| Vec3::splat(1.0 + t);
        let unordered = map.beam(origin, dir, 1.8, weight);
        let mut buffer = Vec::new();
        let mut last = 0.0;
        let ordered = map.beam_in_order(origin, dir, 1.8, &mut buffer, |t, photon| {
            assert!(t >= last, "{t} after {last}");
            last = t;
            weight(t, photon)
        });
        assert!(buffer.len() > 100, "{} photons", buffer.len());
        assert!((ordered - unordered).abs().max_element() < 1e-4 * unordered.x);
    }

    /// Measurement behind the module header's choice, not a check: over photons of a known,
    /// varying density, the beam estimate against Jensen & Christensen's ray marching (steps
    /// of length Δ, each a search of the photons within r, Φ/((4/3)πr³) each), the same
    /// photons and radius: time per ray and RMS relative error against the exact integral.
    /// Run with `cargo test --release --lib -- --ignored --nocapture beam_against_ray_marching`.
    #[test]
    #[ignore]
    fn beam_against_ray_marching() {
        use crate::photon_map::Neighbors;
        let density = |p: Vec3| 1.0 + 0.8 * (3.0 * p.x).sin() * (2.0 * p.y).cos();
        let mut rng = crate::rng::Rng::new(21);
        let n = 400_000;
        let mut photons = Vec::with_capacity(n);
        while photons.len() < n {
            let p = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 2.0;
            if 1.8 * rng.uniform() < density(p) {
                photons.push(p);
            }
        }
        // The density's integral over the cube [0, 2]³ (it varies only in x and y), so that the
        // photons' total power of 1 gives the exact power per unit volume.
        let steps = 200;
        let mut total = 0.0f64;
        for i in 0..steps {
            for j in 0..steps {
                let p = Vec3::new(i as f32 + 0.5, j as f32 + 0.5, 0.0) * (2.0 / steps as f32);
                total += density(p) as f64;
            }
        }
        let volume_integral = total / (steps * steps) as f64 * 8.0;
        let power = 1.0 / n as f32;
        let list: Vec<Photon> = photons
            .iter()
            .map(|&p| Photon::new(p, Vec3::splat(power), Vec3::Z, 1, false))
            .collect();
        let r = 0.08;
        let map = VolumePhotonMap::new(list, r).expect("photons");
        let rays: Vec<(Vec3, Vec3, f32)> = (0..2000)
            .map(|_| {
                let o = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 1.2 + 0.4;
                let d = (Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) - 0.5).normalize();
                // Stay inside [0.2, 1.8]³.
                let mut len = 1.0f32;
                for a in 0..3 {
                    if d[a] > 0.0 {
                        len = len.min((1.8 - o[a]) / d[a]);
                    } else if d[a] < 0.0 {
                        len = len.min((0.2 - o[a]) / d[a]);
                    }
                }
                (o, d, len)
            })
            .collect();
        let exact: Vec<f64> = rays
            .iter()
            .map(|&(o, d, len)| {
                let k = 1000;
                (0..k)
                    .map(|i| density(o + d * ((i as f32 + 0.5) * len / k as f32)) as f64)
                    .sum::<f64>()
                    * (len as f64 / k as f64)
                    / volume_integral
            })
            .collect();
        let report = |name: &str, estimate: &mut dyn FnMut(Vec3, Vec3, f32) -> f32| {
            let start = std::time::Instant::now();
            let got: Vec<f32> = rays
                .iter()
                .map(|&(o, d, len)| estimate(o, d, len))
                .collect();
            let micros = start.elapsed().as_secs_f64() * 1e6 / rays.len() as f64;
            let rms = (got
                .iter()
                .zip(&exact)
                .map(|(&g, &e)| ((g as f64 - e) / e).powi(2))
                .sum::<f64>()
                / rays.len() as f64)
                .sqrt();
            println!("{name}: {micros:.1} µs per ray, RMS relative error {rms:.4}");
        };
        report("beam", &mut |o, d, len| {
            map.beam(o, d, len, |_, _| Vec3::ONE).x
        });
        let mut buf = Neighbors::default();
        for step in [r, 0.5 * r, 0.25 * r] {
            let sphere = 4.0 / 3.0 * PI * r * r * r;
            report(
                &format!("ray marching, step {:.2} r", step / r),
                &mut |o, d, len| {
                    let count = (len / step).ceil().max(1.0) as usize;
                    let dt = len / count as f32;
                    let mut sum = 0.0;
                    for i in 0..count {
                        let x = o + d * ((i as f32 + 0.5) * dt);
                        map.map.nearest(x, 100_000, r * r, &mut buf);
                        let found: f32 = buf
                            .iter()
                            .map(|nb| map.map.photons()[nb.index as usize].power().x)
                            .sum();
                        sum += found / sphere * dt;
                    }
                    sum
                },
            );
        }
    }
}
