//! Distant light: an equirectangular environment map (`EnvironmentLight`) importance-sampled
//! with a 2D piecewise-constant distribution over its pixels weighted by luminance × sin θ,
//! mapped to the sphere with the Jacobian 2π² sin θ (pbrt-v4 §12.5.2, "Image infinite
//! lights"), and the radiance of a sun's disc.

use crate::math::{luminance, Vec2, Vec3};
use crate::sampling::Distribution2D;
use crate::scene::Environment;
use std::f32::consts::PI;

/// Radiance of a uniform sun disk of angular radius acos(cos_max) that gives `irradiance` on a
/// surface facing it: E = L · π sin²θ.
pub(super) fn sun_disk_radiance(irradiance: Vec3, cos_max: f32) -> Vec3 {
    let sin2 = (1.0 - cos_max * cos_max).max(1e-12);
    irradiance / (PI * sin2)
}

/// An equirectangular environment map as a light: radiance lookups by direction and importance
/// sampling of directions (see the module documentation for the method, `scene::Environment`
/// for the mapping).
#[derive(Clone, Debug)]
pub struct EnvironmentLight {
    map: Environment,
    distribution: Distribution2D,
    /// Mean radiance over the sphere, ∫L dω / 4π.
    pub average: Vec3,
}

impl EnvironmentLight {
    pub fn new(map: &Environment) -> Self {
        let (w, h) = (map.width as usize, map.height as usize);
        let lum: Vec<f32> = map.pixels.iter().map(|&c| luminance(c)).collect();
        let mut weights = vec![0.0; w * h];
        let mut sum = Vec3::ZERO;
        for y in 0..h {
            let sin_theta = (PI * (y as f32 + 0.5) / h as f32).sin();
            // Solid angle of a pixel of this row: (2π/w)·(cos θ0 − cos θ1).
            let (theta0, theta1) = (PI * y as f32 / h as f32, PI * (y + 1) as f32 / h as f32);
            let solid_angle = 2.0 * PI / w as f32 * (theta0.cos() - theta1.cos());
            for x in 0..w {
                // Bilinear lookups blend in the neighbours: weigh a pixel by the brightest of
                // its 3×3 neighbourhood so the density is positive wherever radiance is.
                let mut peak = lum[y * w + x];
                if !map.closest {
                    for yy in y.saturating_sub(1)..(y + 2).min(h) {
                        for dx in [w - 1, 0, 1] {
                            peak = peak.max(lum[yy * w + (x + dx) % w]);
                        }
                    }
                }
                weights[y * w + x] = peak * sin_theta;
                sum += map.pixels[y * w + x] * solid_angle;
            }
        }
        let average = sum / (4.0 * PI);
        EnvironmentLight {
            map: map.clone(),
            distribution: Distribution2D::new(&weights, w, h),
            average,
        }
    }

    /// Radiance arriving from direction `dir` (scene space, towards the environment).
    pub fn eval(&self, dir: Vec3) -> Vec3 {
        self.map.radiance(dir)
    }

    /// Solid-angle density with which `sample` picks `dir`.
    pub fn pdf(&self, dir: Vec3) -> f32 {
        let (p, sin_theta) = self.map.to_image(dir);
        if sin_theta <= 0.0 {
            return 0.0;
        }
        self.distribution.pdf(p) / (2.0 * PI * PI * sin_theta)
    }

    /// A direction (scene space, towards the environment), its radiance and solid-angle density.
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, Vec3, f32)> {
        let (p, pdf_image) = self.distribution.sample(u)?;
        let (theta, phi) = (PI * p.y, PI - 2.0 * PI * p.x);
        let sin_theta = theta.sin();
        if sin_theta <= 0.0 {
            return None;
        }
        let d = Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), theta.cos());
        let dir = self.map.to_map.transpose() * d;
        let pdf = pdf_image / (2.0 * PI * PI * sin_theta);
        (pdf > 0.0 && pdf.is_finite()).then(|| (dir, self.eval(dir), pdf))
    }
}
