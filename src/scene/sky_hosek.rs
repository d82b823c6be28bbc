//! Blender's Sky Texture in its Hosek-Wilkie model: the analytic sky dome of Hosek & Wilkie
//! (2012), "An Analytic Model for Full Spectral Sky-Dome Radiance", in its CIE XYZ version. Nine
//! distribution parameters per channel (an extended Perez formula with a Mie-like lobe around
//! the sun and a zenith term) and the channel's overall radiance are interpolated from the
//! authors' fitted data (`sky_hosek_data.rs`): a quintic Bézier curve over the cube root of
//! the sun's elevation, linearly between the ten integer turbidities and between ground albedo
//! 0 and 1. Evaluated as Cycles evaluates the node: the sun clamped to the horizon, directions
//! below the horizon given the horizon's colour, XYZ turned into linear Rec. 709 RGB (negative
//! values clamped) and scaled by 2π/683. There is no sun disc.
//!
//! Directions are in Blender's world frame (Z up), the sun's given as Blender's Sun Direction
//! vector. Units are Cycles': the sky's radiance for a Background strength of 1.

use super::sky::xyz_to_rec709;
use super::sky_hosek_data::{XYZ_CONFIGS, XYZ_RADIANCES};
use super::sky_preetham::{angle_between, spherical, HORIZON_THETA};
use crate::math::Vec3;
use std::f32::consts::FRAC_PI_2;

/// A Hosek-Wilkie sky ready for lookups.
#[derive(Clone, Debug)]
pub struct HosekSky {
    /// Zenith angle (at most the horizon's) and azimuth (`atan2(x, y)`) of the sun.
    sun_theta: f32,
    sun_phi: f32,
    /// The nine distribution parameters of X, Y and Z.
    configs: [[f32; 9]; 3],
    /// The overall radiance of X, Y and Z.
    radiances: [f32; 3],
}

/// The quintic Bézier curve whose six control points are `data[first + k × stride]`, at
/// `t` ∈ [0, 1].
fn bezier(data: &[f64], first: usize, stride: usize, t: f64) -> f64 {
    const BINOMIAL: [f64; 6] = [1.0, 5.0, 10.0, 10.0, 5.0, 1.0];
    (0..6)
        .map(|k| {
            BINOMIAL[k] * (1.0 - t).powi(5 - k as i32) * t.powi(k as i32) * data[first + k * stride]
        })
        .sum()
}

/// The weights of the (albedo, turbidity) corners the data is interpolated between: for each
/// of albedo 0 and 1, the integer turbidity at or below `turbidity` and, below 10, the next.
fn corners(turbidity: f64, albedo: f64) -> Vec<(usize, usize, f64)> {
    let low = (turbidity.floor() as usize).clamp(1, 10);
    let rem = turbidity - low as f64;
    let mut out = Vec::with_capacity(4);
    for (a, weight) in [(0, 1.0 - albedo), (1, albedo)] {
        out.push((a, low - 1, weight * (1.0 - rem)));
        if low < 10 {
            out.push((a, low, weight * rem));
        }
    }
    out
}

impl HosekSky {
    /// The sky for the sun towards `sun_direction` (any length but zero), `turbidity` (1–10)
    /// and the ground's albedo (0–1).
    pub fn new(sun_direction: Vec3, turbidity: f32, ground_albedo: f32) -> HosekSky {
        let (theta, phi) = spherical(sun_direction.normalize_or(Vec3::Z));
        let theta = theta.clamp(0.0, FRAC_PI_2);
        let turbidity = f64::from(turbidity.clamp(1.0, 10.0));
        let albedo = f64::from(ground_albedo.clamp(0.0, 1.0));
        let elevation = f64::from(FRAC_PI_2 - theta);
        let t = (elevation / std::f64::consts::FRAC_PI_2).max(0.0).cbrt();
        let corners = corners(turbidity, albedo);
        let configs = std::array::from_fn(|channel| {
            std::array::from_fn(|i| {
                corners
                    .iter()
                    .map(|&(a, turb, w)| {
                        let first = a * 540 + turb * 54 + i;
                        w * bezier(&XYZ_CONFIGS[channel], first, 9, t)
                    })
                    .sum::<f64>() as f32
            })
        });
        let radiances = std::array::from_fn(|channel| {
            corners
                .iter()
                .map(|&(a, turb, w)| w * bezier(&XYZ_RADIANCES[channel], a * 60 + turb * 6, 1, t))
                .sum::<f64>() as f32
        });
        HosekSky {
            sun_theta: theta,
            sun_phi: phi,
            configs,
            radiances,
        }
    }

    /// Radiance (linear Rec. 709) of the sky along unit `dir`.
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        let (theta, phi) = spherical(dir);
        let gamma = angle_between(theta, phi, self.sun_theta, self.sun_phi);
        let theta = theta.min(HORIZON_THETA);
        let (cos_theta, cos_gamma) = (theta.cos(), gamma.cos());
        let distribution = |c: &[f32; 9]| {
            let mie = (1.0 + cos_gamma * cos_gamma)
                / (1.0 + c[8] * c[8] - 2.0 * c[8] * cos_gamma).powf(1.5);
            (1.0 + c[0] * (c[1] / (cos_theta + 0.01)).exp())
                * (c[2]
                    + c[3] * (c[4] * gamma).exp()
                    + c[5] * cos_gamma * cos_gamma
                    + c[6] * mie
                    + c[7] * cos_theta.sqrt())
        };
        let xyz = Vec3::from_array(std::array::from_fn(|i| {
            distribution(&self.configs[i]) * self.radiances[i]
        }));
        xyz_to_rec709(xyz) * (std::f32::consts::TAU / 683.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// At an integer turbidity, albedo 0 and the sun at the zenith (t = 1) the parameters are
    /// the last control points of that turbidity's row; between turbidities they are blended
    /// linearly. The sky is brighter towards the sun and blue overhead.
    #[test]
    fn the_data_is_interpolated_between_its_corners() {
        let overhead = HosekSky::new(Vec3::Z, 3.0, 0.0);
        for channel in 0..3 {
            for i in 0..9 {
                let expected = XYZ_CONFIGS[channel][2 * 54 + 45 + i] as f32;
                assert!((overhead.configs[channel][i] - expected).abs() < 1e-5);
            }
            let expected = XYZ_RADIANCES[channel][2 * 6 + 5] as f32;
            assert!((overhead.radiances[channel] - expected).abs() < 1e-5);
        }
        let sun = Vec3::new(0.0, 0.8, 0.6);
        let (a, b) = (HosekSky::new(sun, 4.0, 0.5), HosekSky::new(sun, 5.0, 0.5));
        let mid = HosekSky::new(sun, 4.5, 0.5);
        for i in 0..9 {
            let blend = 0.5 * (a.configs[1][i] + b.configs[1][i]);
            assert!((mid.configs[1][i] - blend).abs() < 1e-4 * (1.0 + blend.abs()));
        }
        let towards = mid.radiance(Vec3::new(0.0, 0.9, 0.3).normalize());
        let away = mid.radiance(Vec3::new(0.0, -0.9, 0.3).normalize());
        assert!(towards.y > 2.0 * away.y, "{towards} {away}");
        let zenith = mid.radiance(Vec3::Z);
        assert!(zenith.z > zenith.x && zenith.y > 0.0, "{zenith}");
    }
}
