//! Rendering in rounds under a time limit: the image is the sample-weighted average of rounds of
//! `round_spp` samples, each with its own seed, and no new round starts once the time is up (the
//! first round always completes). The same settings and number of completed rounds give the same
//! image bit for bit; round 0 uses the caller's seed, so one round equals a plain render.
//!
//! The acceleration structure is built once. Photon maps and irradiance caches are built per
//! generation of `render::GENERATION_SPP` samples per pixel, whatever the rounds
//! (`render::render_scheduled`): each generation traces fresh photons and places fresh records
//! with smaller radii and a tighter cache (Knaus & Zwicker 2011's probabilistic progressive
//! photon mapping), so the error of the photon methods keeps falling as samples accumulate.

use crate::accel::Accel;
use crate::error::Result;
use crate::film::Image;
use crate::progress::Progress;
use crate::render::{render_scheduled, RenderSettings, RenderStats};
use crate::scene::Scene;
use std::time::{Duration, Instant};

/// The result of a render in rounds.
pub struct RoundsResult {
    pub image: Image,
    pub stats: RenderStats,
    pub rounds: u32,
    /// Samples per pixel actually rendered.
    pub spp: u32,
}

/// Seed of round `index`: the caller's for round 0, a well-mixed distinct one for the others.
fn round_seed(seed: u64, index: u32) -> u64 {
    if index == 0 {
        seed
    } else {
        seed ^ (index as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15)
    }
}

/// Render up to `settings.spp` samples per pixel in rounds of `round_spp`, stopping between rounds
/// once `time_limit` has elapsed; `accel` is the scene's BVH when already built.
pub fn render_in_rounds(
    scene: &Scene,
    accel: Option<&Accel>,
    settings: &RenderSettings,
    round_spp: u32,
    time_limit: Option<Duration>,
    progress: &Progress,
) -> Result<RoundsResult> {
    let start = Instant::now();
    let round_spp = round_spp.clamp(1, settings.spp.max(1));
    let mut total: Option<Image> = None;
    let mut done_spp = 0u32;
    let mut rounds = 0u32;
    let stats = render_scheduled(scene, accel, settings, progress, &mut |finished| {
        if let Some((image, spp)) = finished {
            total = Some(match total.take() {
                None => image,
                Some(sum) => sum.merge(&image),
            });
            done_spp += spp;
            rounds += 1;
        }
        let time_up = rounds > 0 && time_limit.is_some_and(|limit| start.elapsed() >= limit);
        (done_spp < settings.spp && !time_up).then(|| {
            let spp = round_spp.min(settings.spp - done_spp);
            (round_seed(settings.seed, rounds), spp)
        })
    })?;
    let image = total.ok_or_else(|| {
        crate::error::Error::Settings("samples per pixel must be at least 1".into())
    })?;
    Ok(RoundsResult {
        image,
        stats,
        rounds,
        spp: done_spp,
    })
}
