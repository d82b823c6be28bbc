//! The image being rendered: per-pixel sums of filtered samples, and the pixel filter.
//!
//! Like Cycles, Photon importance-samples its pixel filter (separably in x and y, by inverting
//! its tabulated CDF) instead of splatting. The three filters are Blender's (Render Properties →
//! Film → Pixel Filter) with Cycles' definitions (intern/cycles/scene/film.cpp): a Blender width
//! w is a window Cycles widens before building its table — Blackman–Harris over 2w (samples
//! within ±w), Gaussian over 3w (samples within ±1.5w, exp(−8x²/w²), a standard deviation of
//! w/4), Box over w (uniform within ±w/2; Blender always gives Cycles a 1-px box). Every sample
//! belongs to exactly one pixel with weight 1, so pixels are independent, tiles render in
//! parallel and images are bit-identical for any number of threads.

use crate::error::{Error, Result};
use crate::light_pass::Passes;
use crate::math::{Mat3, Vec2, Vec3};

/// Blender's pixel filter types (Cycles' `FilterType`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FilterKind {
    /// Blender's default: the 4-term Blackman–Harris window.
    #[default]
    BlackmanHarris,
    /// A Gaussian of standard deviation width/4, cut at ±1.5 width.
    Gaussian,
    /// Uniform over the width.
    Box,
}

/// A pixel filter as Blender sets it: a type and a width in pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterSettings {
    pub kind: FilterKind,
    /// Blender's "Width" in pixels.
    pub width: f32,
}

impl Default for FilterSettings {
    /// Blender's default filter: Blackman–Harris, 1.5 px.
    fn default() -> Self {
        FilterSettings {
            kind: FilterKind::BlackmanHarris,
            width: 1.5,
        }
    }
}

impl FilterSettings {
    /// Narrowest and widest filter Blender's Width field accepts, in pixels.
    pub const MIN_WIDTH: f32 = 0.01;
    pub const MAX_WIDTH: f32 = 10.0;

    /// A filter of `kind` and `width` pixels; widths outside Blender's range are refused.
    pub fn new(kind: FilterKind, width: f32) -> Result<Self> {
        if !(Self::MIN_WIDTH..=Self::MAX_WIDTH).contains(&width) {
            return Err(Error::Settings(format!(
                "pixel filter width {width} is outside Blender's range {}..{} px",
                Self::MIN_WIDTH,
                Self::MAX_WIDTH
            )));
        }
        Ok(FilterSettings { kind, width })
    }

    /// Parse `TYPE[:WIDTH]` (`blackman-harris`, `gaussian` or `box`; Blender's enum names and
    /// `_` for `-` also read); without a width, Blender's default for the type (1.5 px, box 1 px).
    pub fn parse(text: &str) -> Result<Self> {
        let (name, width) = match text.split_once(':') {
            Some((name, width)) => (name, Some(width)),
            None => (text, None),
        };
        let kind = FilterKind::from_name(name).ok_or_else(|| {
            Error::Settings(format!(
                "unknown pixel filter '{name}' (valid: blackman-harris, gaussian, box, \
                 optionally with :WIDTH in pixels)"
            ))
        })?;
        let width = match width {
            None => kind.default_width(),
            Some(w) => w.trim().parse::<f32>().map_err(|_| {
                Error::Settings(format!("pixel filter width '{w}' is not a number"))
            })?,
        };
        Self::new(kind, width)
    }

    /// The half-width of the window samples fall in, in pixels.
    pub fn radius(&self) -> f32 {
        0.5 * self.table_width()
    }

    /// The width Cycles builds its table over (see the module documentation).
    fn table_width(&self) -> f32 {
        match self.kind {
            FilterKind::BlackmanHarris => 2.0 * self.width,
            FilterKind::Gaussian => 3.0 * self.width,
            FilterKind::Box => self.width,
        }
    }

    /// The filter's (unnormalised) weight at offset `x` pixels from the pixel centre; zero
    /// outside `radius()`.
    pub fn weight(&self, x: f32) -> f32 {
        let table = self.table_width();
        if x.abs() > 0.5 * table {
            return 0.0;
        }
        match self.kind {
            FilterKind::BlackmanHarris => PixelFilter::blackman_harris(table, x).max(0.0),
            FilterKind::Gaussian => {
                let v = x * 6.0 / table;
                (-2.0 * v * v).exp()
            }
            FilterKind::Box => 1.0,
        }
    }
}

impl std::fmt::Display for FilterSettings {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        write!(f, "{}:{}", self.kind.name(), self.width)
    }
}

impl FilterKind {
    /// The command line's name.
    pub fn name(self) -> &'static str {
        match self {
            FilterKind::BlackmanHarris => "blackman-harris",
            FilterKind::Gaussian => "gaussian",
            FilterKind::Box => "box",
        }
    }

    /// The kind named `name`: the command line's names or Blender's enum identifiers
    /// (`BLACKMAN_HARRIS`, `GAUSSIAN`, `BOX`), in any case.
    pub fn from_name(name: &str) -> Option<FilterKind> {
        match name.trim().to_ascii_lowercase().replace('_', "-").as_str() {
            "blackman-harris" => Some(FilterKind::BlackmanHarris),
            "gaussian" => Some(FilterKind::Gaussian),
            "box" => Some(FilterKind::Box),
            _ => None,
        }
    }

    /// Blender's width for a filter of this kind: 1.5 px, and 1 px for the box, the width
    /// Blender always gives Cycles for it.
    pub fn default_width(self) -> f32 {
        match self {
            FilterKind::Box => 1.0,
            _ => 1.5,
        }
    }
}

/// A pixel filter ready for sampling: its CDF on a fine grid, inverted exactly (the density
/// piecewise constant over `STEPS` cells). Cycles instead interpolates an inverse-CDF table of
/// 1024 evenly spaced CDF values, which puts a few too many samples in the filter's far tails
/// (where the inverse CDF is steep); this sampler follows the filter itself.
pub struct PixelFilter {
    /// Half-width of the window, in pixels.
    radius: f32,
    /// `cdf[i]`: the share of the filter left of −radius + 2·radius·i / STEPS; `cdf[STEPS]` = 1.
    cdf: Vec<f32>,
    /// `guide[b]`: the last cell whose CDF starts at or below b / GUIDE, where the search for a
    /// `u` in [b / GUIDE, (b + 1) / GUIDE) starts (about one step on average, where a binary
    /// search over the cells took twelve unpredictable ones).
    guide: Vec<u32>,
}

impl PixelFilter {
    /// Grid cells of the CDF.
    const STEPS: usize = 4096;
    /// Buckets of the guide table.
    const GUIDE: usize = 4096;

    /// The 4-term Blackman–Harris window over [−width/2, width/2].
    pub fn blackman_harris(width: f32, x: f32) -> f32 {
        let a = std::f32::consts::TAU * (x / width + 0.5);
        0.35875 - 0.48829 * a.cos() + 0.14128 * (2.0 * a).cos() - 0.01168 * (3.0 * a).cos()
    }

    /// The sampler of `settings`.
    pub fn new(settings: &FilterSettings) -> Self {
        let radius = settings.radius();
        let cell = 2.0 * radius as f64 / Self::STEPS as f64;
        // Cumulative integral of the window, each cell weighted by its midpoint's value.
        let mut sums = Vec::with_capacity(Self::STEPS + 1);
        sums.push(0.0f64);
        for i in 0..Self::STEPS {
            let x = -radius as f64 + cell * (i as f64 + 0.5);
            sums.push(sums[i] + settings.weight(x as f32) as f64);
        }
        let total = sums[Self::STEPS].max(1e-300);
        let mut cdf: Vec<f32> = sums.iter().map(|s| (s / total) as f32).collect();
        cdf[Self::STEPS] = 1.0;
        let guide = (0..Self::GUIDE)
            .map(|b| {
                let start = b as f32 / Self::GUIDE as f32;
                (cdf.partition_point(|&c| c <= start).max(1) - 1).min(Self::STEPS - 1) as u32
            })
            .collect();
        PixelFilter { radius, cdf, guide }
    }

    /// Half-width of the window, in pixels: no offset reaches farther.
    pub fn radius(&self) -> f32 {
        self.radius
    }

    /// The offset (pixels) at CDF value `u` ∈ [0, 1] along one axis.
    pub fn sample_1d(&self, u: f32) -> f32 {
        // The cell whose CDF interval holds u (cells of zero weight are never chosen): the last
        // cell whose CDF starts at or below u, searched on from the guide's.
        let bucket = ((u * Self::GUIDE as f32) as usize).min(Self::GUIDE - 1);
        let mut j = self.guide[bucket] as usize;
        while j + 1 < Self::STEPS && self.cdf[j + 1] <= u {
            j += 1;
        }
        let span = self.cdf[j + 1] - self.cdf[j];
        let frac = if span > 0.0 {
            ((u - self.cdf[j]) / span).clamp(0.0, 1.0)
        } else {
            0.5
        };
        -self.radius + 2.0 * self.radius * (j as f32 + frac) / Self::STEPS as f32
    }

    /// Offset from the pixel centre, distributed as the filter.
    pub fn sample(&self, u: Vec2) -> Vec2 {
        Vec2::new(self.sample_1d(u.x), self.sample_1d(u.y))
    }
}

impl Default for PixelFilter {
    fn default() -> Self {
        Self::new(&FilterSettings::default())
    }
}

/// The depth of a pixel none of whose samples hit anything (Blender's Z of the background).
pub const NO_HIT_DEPTH: f32 = 1e10;

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
    /// Distance from the camera to the first surface, averaged over the samples that hit
    /// something; `NO_HIT_DEPTH` where none did (Blender's Z).
    pub depth: Vec<f32>,
    /// Radiance by light path (`light_pass::LightPass`), filtered like `rgba`, so the passes
    /// of a pixel add up to its colour (all zero for the debug views of the cache). Empty
    /// unless `RenderSettings::light_passes` asked for them.
    pub passes: Vec<Passes>,
    /// Camera-to-world rotation, to express normals in camera space (Blender's Denoising Normal).
    pub camera_rotation: Mat3,
    /// Camera samples taken per pixel (Cycles' Sample Count pass): all the same unless adaptive
    /// sampling stopped some pixels early (`adaptive`).
    pub samples: Vec<u32>,
    /// Cycles' Shadow Catcher pass: per pixel the light the shadow catchers keep of what they
    /// receive without the other objects, over white by the pixel's alpha (1 where no catcher
    /// is seen; `shadow_catcher::CatcherSum::compose`). Empty for scenes without catchers.
    pub shadow_catcher: Vec<Vec3>,
    /// Text attributes of the EXR header (name, value): the samples the image holds
    /// (`exr_merge::SampleRanges`). Not written to PNG.
    pub metadata: Vec<(String, String)>,
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
            samples: vec![0; n],
            shadow_catcher: Vec::new(),
            metadata: Vec::new(),
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
    /// The average of this image and `other` weighted by each pixel's samples (`samples`): the
    /// image of all their samples together. A pixel neither sampled keeps this image's values.
    pub fn merge(mut self, other: &Image) -> Image {
        for k in 0..self.rgba.len() {
            let (own, more) = (self.samples[k], other.samples[k]);
            let total = (own + more) as f32;
            if total == 0.0 {
                continue;
            }
            let (a, b) = (own as f32 / total, more as f32 / total);
            let (s, p) = (&mut self.rgba[k], other.rgba[k]);
            for c in 0..4 {
                s[c] = s[c] * a + p[c] * b;
            }
            self.albedo[k] = self.albedo[k] * a + other.albedo[k] * b;
            self.normal[k] = (self.normal[k] * a + other.normal[k] * b).normalize_or_zero();
            if let (Some(s), Some(p)) =
                (self.shadow_catcher.get_mut(k), other.shadow_catcher.get(k))
            {
                *s = *s * a + *p * b;
            }
            if let (Some(s), Some(p)) = (self.passes.get_mut(k), other.passes.get(k)) {
                let mut p = *p;
                p.scale(b);
                s.scale(a);
                *s += p;
            }
            // Depth is a mean over the samples that hit something: the parts' means weighted by
            // their samples (by their hits at silhouettes, which the images do not keep).
            if more > 0 {
                let (d, e) = (self.depth[k], other.depth[k]);
                self.depth[k] = match (own > 0 && d < NO_HIT_DEPTH, e < NO_HIT_DEPTH) {
                    (true, true) => d * a + e * b,
                    (true, false) => d,
                    (false, _) => e,
                };
            }
            self.samples[k] = own + more;
        }
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn filter_names_and_widths_parse_as_blender_names_them() {
        let f = FilterSettings::parse("gaussian:3").unwrap();
        assert_eq!((f.kind, f.width), (FilterKind::Gaussian, 3.0));
        assert_eq!(FilterSettings::parse("BOX").unwrap().width, 1.0);
        let bh = FilterSettings::parse("blackman_harris").unwrap();
        assert_eq!(bh, FilterSettings::default());
        assert_eq!(FilterSettings::parse(&bh.to_string()).unwrap(), bh);
        for bad in [
            "mitchell",
            "box:",
            "gaussian:wide",
            "box:0",
            "gaussian:-1",
            "box:nan",
        ] {
            assert!(FilterSettings::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn guided_search_finds_the_cell_a_binary_search_finds() {
        for settings in [
            FilterSettings::default(),
            FilterSettings::new(FilterKind::Gaussian, 3.0).unwrap(),
            FilterSettings::new(FilterKind::Box, 1.0).unwrap(),
        ] {
            let f = PixelFilter::new(&settings);
            let steps = PixelFilter::STEPS;
            let by_bisection = |u: f32| {
                let j = (f.cdf.partition_point(|&c| c <= u).max(1) - 1).min(steps - 1);
                let span = f.cdf[j + 1] - f.cdf[j];
                let frac = if span > 0.0 {
                    ((u - f.cdf[j]) / span).clamp(0.0, 1.0)
                } else {
                    0.5
                };
                -f.radius + 2.0 * f.radius * (j as f32 + frac) / steps as f32
            };
            // Every CDF value itself (the cells' edges) and points between them.
            let edges = f.cdf.iter().copied();
            let between = (0..100_000).map(|i| (i as f32 + 0.37) / 100_000.0);
            for u in edges.chain(between).chain([0.0, 1.0, 0.99999994]) {
                assert_eq!(f.sample_1d(u), by_bisection(u), "{settings:?} u = {u}");
            }
        }
    }

    #[test]
    fn samples_stay_within_each_filters_support() {
        for (kind, width, radius) in [
            (FilterKind::BlackmanHarris, 1.5, 1.5),
            (FilterKind::Gaussian, 3.0, 4.5),
            (FilterKind::Box, 1.0, 0.5),
        ] {
            let settings = FilterSettings::new(kind, width).unwrap();
            assert_eq!(settings.radius(), radius);
            let f = PixelFilter::new(&settings);
            // The ends of the window, to within a cell of the table.
            assert!((f.sample_1d(0.0) + radius).abs() < 5e-3, "{kind:?}");
            assert!((f.sample_1d(1.0) - radius).abs() < 5e-3, "{kind:?}");
            assert!(f.sample_1d(0.5).abs() < 1e-3, "{kind:?}");
        }
    }
}
