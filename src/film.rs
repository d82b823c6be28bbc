//! The image being rendered: per-pixel sums of filtered samples, and the pixel filter.
//!
//! Like Cycles, Photon importance-samples its pixel filter (Blackman–Harris, sampled separably in
//! x and y by an inverse-CDF table) instead of splatting. Blender's "1.5 px" filter width is, in
//! Cycles, a window twice that wide: Cycles doubles the width for Blackman–Harris before building
//! its table (intern/cycles/scene/film.cpp), so samples spread over ±1.5 px. Every sample
//! belongs to exactly one pixel with weight 1, so pixels are independent, tiles render in parallel
//! and images are bit-identical for any number of threads.

use crate::light_pass::Passes;
use crate::math::{Mat3, Vec2, Vec3};

/// The Blackman–Harris pixel filter, sampled by table inversion.
pub struct PixelFilter {
    /// Inverse CDF: `inverse_cdf[i]` is the offset (in pixels) at CDF value i / (N − 1).
    inverse_cdf: Vec<f32>,
}

impl PixelFilter {
    /// Blender's default filter width in pixels (Render Properties → Film → Pixel Filter).
    pub const DEFAULT_WIDTH: f32 = 1.5;

    /// The 4-term Blackman–Harris window over [−width/2, width/2].
    pub fn blackman_harris(width: f32, x: f32) -> f32 {
        let a = std::f32::consts::TAU * (x / width + 0.5);
        0.35875 - 0.48829 * a.cos() + 0.14128 * (2.0 * a).cos() - 0.01168 * (3.0 * a).cos()
    }

    /// The filter Blender calls `blender_width` pixels wide: a Blackman–Harris window over
    /// [−width, width] (see the module documentation).
    pub fn new(blender_width: f32) -> Self {
        let width = 2.0 * blender_width;
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
    /// Radiance by light path (`light_pass::LightPass`), filtered like `rgba`, so the passes
    /// of a pixel add up to its colour (all zero for the debug views of the cache). Empty
    /// unless `RenderSettings::light_passes` asked for them.
    pub passes: Vec<Passes>,
    /// Camera-to-world rotation, to express normals in camera space (Blender's Denoising Normal).
    pub camera_rotation: Mat3,
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
            passes: Vec::new(),
            camera_rotation: Mat3::IDENTITY,
        }
    }

    /// The first-hit normal of pixel `i` in camera space (x right, y up, z towards the viewer).
    pub fn camera_space_normal(&self, i: usize) -> Vec3 {
        self.camera_rotation.transpose() * self.normal[i]
    }

    /// Mean of R, G and B over all pixels.
    pub fn mean_rgb(&self) -> Vec3 {
        let sum = self
            .rgba
            .iter()
            .fold(Vec3::ZERO, |s, p| s + Vec3::new(p[0], p[1], p[2]));
        sum / self.rgba.len().max(1) as f32
    }

    /// The sample-weighted average of this image (of `own_spp` samples per pixel) and `other`
    /// (of `other_spp`): colour, AOVs and light passes averaged, depth the nearest.
    pub fn merge(mut self, own_spp: u32, other: &Image, other_spp: u32) -> Image {
        let total = (own_spp + other_spp) as f32;
        let (a, b) = (own_spp as f32 / total, other_spp as f32 / total);
        for (s, p) in self.rgba.iter_mut().zip(&other.rgba) {
            for c in 0..4 {
                s[c] = s[c] * a + p[c] * b;
            }
        }
        for (s, p) in self.albedo.iter_mut().zip(&other.albedo) {
            *s = *s * a + *p * b;
        }
        for (s, p) in self.normal.iter_mut().zip(&other.normal) {
            *s = (*s * a + *p * b).normalize_or_zero();
        }
        for (s, p) in self.passes.iter_mut().zip(&other.passes) {
            let mut p = *p;
            p.scale(b);
            s.scale(a);
            *s += p;
        }
        for (s, p) in self.depth.iter_mut().zip(&other.depth) {
            *s = s.min(*p);
        }
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn filter_samples_follow_the_window() {
        // Blender's 1.5 px filter is a Blackman–Harris window over [−1.5, 1.5] px.
        let f = PixelFilter::default();
        let (half, bins, n) = (1.5f32, 30, 300_000);
        let window = |x: f32| PixelFilter::blackman_harris(2.0 * half, x);
        let mut hist = vec![0usize; bins];
        for i in 0..n {
            let x = f.lookup((i as f32 + 0.5) / n as f32);
            assert!(x.abs() <= half + 1e-6);
            hist[(((x + half) / (2.0 * half) * bins as f32) as usize).min(bins - 1)] += 1;
        }
        let steps = 1000;
        let dx = 2.0 * half / steps as f32;
        let norm: f32 = (0..steps)
            .map(|i| window(-half + (i as f32 + 0.5) * dx) * dx)
            .sum();
        for (b, &count) in hist.iter().enumerate() {
            let width = 2.0 * half / bins as f32;
            let expected = window(-half + (b as f32 + 0.5) * width) / norm * width;
            assert!(
                (count as f32 / n as f32 - expected).abs() < 0.002,
                "bin {b}"
            );
        }
    }
}
