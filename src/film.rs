//! The image being rendered: per-pixel sums of filtered samples, and the pixel filter.
//!
//! Like Cycles, Photon importance-samples its pixel filter (a Blackman–Harris window 1.5 pixels
//! wide, sampled separably in x and y by an inverse-CDF table) instead of splatting: every sample
//! belongs to exactly one pixel with weight 1, so pixels are independent, tiles render in parallel
//! and images are bit-identical for any number of threads.

use crate::math::{Vec2, Vec3};

/// The Blackman–Harris pixel filter, sampled by table inversion.
pub struct PixelFilter {
    /// Inverse CDF: `inverse_cdf[i]` is the offset (in pixels) at CDF value i / (N − 1).
    inverse_cdf: Vec<f32>,
}

impl PixelFilter {
    /// Cycles' default filter width in pixels.
    pub const DEFAULT_WIDTH: f32 = 1.5;

    /// The 4-term Blackman–Harris window over [−width/2, width/2].
    pub fn blackman_harris(width: f32, x: f32) -> f32 {
        let a = std::f32::consts::TAU * (x / width + 0.5);
        0.35875 - 0.48829 * a.cos() + 0.14128 * (2.0 * a).cos() - 0.01168 * (3.0 * a).cos()
    }

    pub fn new(width: f32) -> Self {
        const STEPS: usize = 1024;
        const TABLE: usize = 256;
        // Cumulative integral of the window on a fine grid.
        let mut cdf = Vec::with_capacity(STEPS + 1);
        cdf.push(0.0f64);
        for i in 0..STEPS {
            let x = -0.5 * width + width * (i as f32 + 0.5) / STEPS as f32;
            let value = Self::blackman_harris(width, x).max(0.0) as f64;
            cdf.push(cdf[i] + value);
        }
        let total = cdf[STEPS];
        let mut inverse_cdf = Vec::with_capacity(TABLE);
        let mut j = 0;
        for k in 0..TABLE {
            let target = total * k as f64 / (TABLE - 1) as f64;
            while j < STEPS - 1 && cdf[j + 1] < target {
                j += 1;
            }
            let span = (cdf[j + 1] - cdf[j]).max(1e-30);
            let frac = ((target - cdf[j]) / span).clamp(0.0, 1.0);
            inverse_cdf.push(-0.5 * width + width * (j as f32 + frac as f32) / STEPS as f32);
        }
        PixelFilter { inverse_cdf }
    }

    fn lookup(&self, u: f32) -> f32 {
        let x = u * (self.inverse_cdf.len() - 1) as f32;
        let i = (x as usize).min(self.inverse_cdf.len() - 2);
        let f = x - i as f32;
        self.inverse_cdf[i] * (1.0 - f) + self.inverse_cdf[i + 1] * f
    }

    /// Offset from the pixel centre, distributed as the filter.
    pub fn sample(&self, u: Vec2) -> Vec2 {
        Vec2::new(self.lookup(u.x), self.lookup(u.y))
    }
}

impl Default for PixelFilter {
    fn default() -> Self {
        Self::new(Self::DEFAULT_WIDTH)
    }
}

/// A rendered image with its auxiliary passes. Row 0 is the top row.
#[derive(Clone, Debug)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    /// Linear RGB radiance and alpha (fraction of camera samples that hit geometry).
    pub rgba: Vec<[f32; 4]>,
    /// Base colour of the first surface (Denoising Albedo).
    pub albedo: Vec<Vec3>,
    /// World-space shading normal of the first surface (Denoising Normal).
    pub normal: Vec<Vec3>,
    /// Distance from the camera to the first surface; 1e10 for the background (Blender's Z).
    pub depth: Vec<f32>,
}

impl Image {
    pub fn new(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Image {
            width,
            height,
            rgba: vec![[0.0; 4]; n],
            albedo: vec![Vec3::ZERO; n],
            normal: vec![Vec3::ZERO; n],
            depth: vec![0.0; n],
        }
    }

    /// Mean of R, G and B over all pixels.
    pub fn mean_rgb(&self) -> Vec3 {
        let sum = self
            .rgba
            .iter()
            .fold(Vec3::ZERO, |s, p| s + Vec3::new(p[0], p[1], p[2]));
        sum / self.rgba.len().max(1) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn filter_samples_follow_the_window() {
        let f = PixelFilter::default();
        // Histogram of samples against the normalised window.
        let bins = 30;
        let mut hist = vec![0usize; bins];
        let n = 300_000;
        for i in 0..n {
            let x = f.lookup((i as f32 + 0.5) / n as f32);
            assert!(x.abs() <= 0.75 + 1e-6);
            hist[(((x + 0.75) / 1.5 * bins as f32) as usize).min(bins - 1)] += 1;
        }
        let norm: f32 = (0..1000)
            .map(|i| {
                PixelFilter::blackman_harris(1.5, -0.75 + 1.5 * (i as f32 + 0.5) / 1000.0) * 1.5
                    / 1000.0
            })
            .sum();
        for (b, &count) in hist.iter().enumerate() {
            let x = -0.75 + 1.5 * (b as f32 + 0.5) / bins as f32;
            let expected = PixelFilter::blackman_harris(1.5, x) / norm * 1.5 / bins as f32;
            assert!(
                (count as f32 / n as f32 - expected).abs() < 0.002,
                "bin {b}"
            );
        }
    }
}
