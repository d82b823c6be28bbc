//! Rendering in passes under a time limit: the image is the sample-weighted average of passes of
//! `pass_spp` samples, each with its own seed, and no new pass starts once the time
//! is up (the first pass always completes). The same settings and number of completed passes give
//! the same image bit for bit; pass 0 uses the caller's seed, so one pass equals a plain render.
//!
//! The acceleration structure, photon maps and irradiance cache are built once, with the
//! caller's seed, and shared by all passes (`render::render_scheduled`): before, every 4-spp
//! pass rebuilt them, which made a time-limited photon render mostly photon tracing.

use crate::accel::Accel;
use crate::error::Result;
use crate::film::Image;
use crate::render::{render_scheduled, Progress, RenderSettings, RenderStats};
use crate::scene::Scene;
use std::time::{Duration, Instant};

/// The result of a render in passes.
pub struct PassesResult {
    pub image: Image,
    pub stats: RenderStats,
    pub passes: u32,
    /// Samples per pixel actually rendered.
    pub spp: u32,
}

/// Seed of pass `index`: the caller's for pass 0, a well-mixed distinct one for the others.
fn pass_seed(seed: u64, index: u32) -> u64 {
    if index == 0 {
        seed
    } else {
        seed ^ (index as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15)
    }
}

/// Render up to `settings.spp` samples per pixel in passes of `pass_spp`, stopping between passes
/// once `time_limit` has elapsed; `accel` is the scene's BVH when already built.
pub fn render_in_passes(
    scene: &Scene,
    accel: Option<&Accel>,
    settings: &RenderSettings,
    pass_spp: u32,
    time_limit: Option<Duration>,
    progress: &Progress,
) -> Result<PassesResult> {
    let start = Instant::now();
    let pass_spp = pass_spp.clamp(1, settings.spp.max(1));
    let mut total: Option<Image> = None;
    let mut done_spp = 0u32;
    let mut passes = 0u32;
    let stats = render_scheduled(scene, accel, settings, progress, &mut |finished| {
        if let Some((image, spp)) = finished {
            total = Some(match total.take() {
                None => image,
                Some(sum) => merge(sum, done_spp, &image, spp),
            });
            done_spp += spp;
            passes += 1;
        }
        let time_up = passes > 0 && time_limit.is_some_and(|limit| start.elapsed() >= limit);
        (done_spp < settings.spp && !time_up).then(|| {
            let spp = pass_spp.min(settings.spp - done_spp);
            (pass_seed(settings.seed, passes), spp)
        })
    })?;
    let image = total.ok_or_else(|| {
        crate::error::Error::Settings("samples per pixel must be at least 1".into())
    })?;
    Ok(PassesResult {
        image,
        stats,
        passes,
        spp: done_spp,
    })
}

/// Average `sum` (of `sum_spp` samples) with `pass` (of `pass_spp`), weighting by samples.
fn merge(mut sum: Image, sum_spp: u32, pass: &Image, pass_spp: u32) -> Image {
    let total = (sum_spp + pass_spp) as f32;
    let (a, b) = (sum_spp as f32 / total, pass_spp as f32 / total);
    for (s, p) in sum.rgba.iter_mut().zip(&pass.rgba) {
        for c in 0..4 {
            s[c] = s[c] * a + p[c] * b;
        }
    }
    for (s, p) in sum.albedo.iter_mut().zip(&pass.albedo) {
        *s = *s * a + *p * b;
    }
    for (s, p) in sum.normal.iter_mut().zip(&pass.normal) {
        *s = (*s * a + *p * b).normalize_or_zero();
    }
    for (s, p) in sum.passes.iter_mut().zip(&pass.passes) {
        let mut p = *p;
        p.scale(b);
        s.scale(a);
        *s += p;
    }
    for (s, p) in sum.depth.iter_mut().zip(&pass.depth) {
        *s = s.min(*p);
    }
    sum
}
