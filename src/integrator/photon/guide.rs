//! Guided photon emission: photons leave each light where they reach what the render reads,
//! after the idea of Peter & Pietrek (1998, "Importance driven construction of photon maps"),
//! with a piecewise-constant density over the light's sample space instead of their importance
//! map, kept unbiased by a defensive mixture (Hesterberg 1995).
//!
//! A sun, a sky or a lamp outside a room lights the room only through its windows: emitted
//! uniformly, most photons land outside, where nothing reads them, and the few that enter carry
//! the whole room's indirect light. Their number varies from one seed to the next, and so does
//! the brightness of the room (a window-lit room's mean moved by ±4 % between seeds).
//!
//! 1. **What the render reads** (`ReadRegion`): camera paths of a few bounces are traced from a
//!    grid over the image; every surface they meet that stores photons marks its cell of a voxel
//!    grid, with the side of the surface it was met on (six axis directions), so the outside
//!    face of a zero-thickness wall is not confused with the inside face the camera sees.
//! 2. **Where each light's photons go** (`EmissionGuide`): the unit square that places a
//!    light's photon (the parallel ray's position on the disc for a sun, the direction for a
//!    point or spot; for the world the direction square as well, as an outer grid) is split into
//!    cells, and a few pilot photons per cell are traced with the render's own photon walk. A
//!    cell's weight is the power its photons store in the read region.
//! 3. **Emission**: a photon's square point is drawn with density `p = (1 − α)·w/Σw + α`
//!    per unit area (the uniform share α keeps every cell possible) and its power divides by p:
//!    the estimate stays unbiased whatever the pilot missed. A light whose uniform photons
//!    already mostly reach the read region is left uniform; so are emissive triangles (many,
//!    and rarely outside what they light).

use crate::accel::{Ray, Visibility};
use crate::camera::CameraRays;
use crate::integrator::classify::stores_photons;
use crate::integrator::shading::Shading;
use crate::integrator::Context;
use crate::light::LightSource;
use crate::math::{Vec2, Vec3};
use crate::rng::Rng;
use crate::sampling::Distribution2D;
use crate::scene::Bounds;
use rayon::prelude::*;

/// Camera-path origins across the image's width when marking the read region.
const READ_PATHS_ACROSS: u32 = 64;
/// Surfaces a camera path marks (the first hit and the bounces after it).
const READ_HITS: u32 = 3;
/// Cells along the longest side of the read region's grid.
const READ_CELLS: f32 = 40.0;
/// How much the bounds of what the camera sees directly grow (as a share of their diagonal) to
/// hold the read region: bounced hits farther out are left unmarked.
const READ_MARGIN: f32 = 0.25;
/// A surface point marks the side directions whose cosine with its normal exceeds this.
const SIDE_COS: f32 = 0.3;

/// Pilot photons traced per guided light.
const PILOT_PHOTONS: u32 = 16_384;
/// Lights guided at most (the brightest); the others emit uniformly.
const MAX_GUIDED_LIGHTS: usize = 8;
/// Share of a guided light's photons emitted uniformly (the defensive mixture's α).
const UNIFORM_SHARE: f32 = 0.1;
/// A light whose uniform photons store at least this share of their power in the read region
/// is not guided: there is little to gain.
const MAX_USEFUL_SHARE: f32 = 0.5;

/// The surfaces (cell and side) that camera paths of a few bounces meet: where the render reads
/// photon estimates.
pub struct ReadRegion {
    lo: Vec3,
    inv_cell: f32,
    dims: [usize; 3],
    /// One byte per cell; bit d set when side direction d (+x, −x, +y, −y, +z, −z) is read.
    sides: Vec<u8>,
}

/// The side direction (0..6) closest to `n`.
fn side_of(n: Vec3) -> usize {
    let a = n.abs();
    if a.x >= a.y && a.x >= a.z {
        usize::from(n.x < 0.0)
    } else if a.y >= a.z {
        2 + usize::from(n.y < 0.0)
    } else {
        4 + usize::from(n.z < 0.0)
    }
}

/// The side directions within `SIDE_COS` of `n`, as bits.
fn sides_near(n: Vec3) -> u8 {
    let mut bits = 0u8;
    for (axis, c) in [n.x, n.y, n.z].into_iter().enumerate() {
        if c > SIDE_COS {
            bits |= 1 << (2 * axis);
        }
        if c < -SIDE_COS {
            bits |= 1 << (2 * axis + 1);
        }
    }
    bits
}

impl ReadRegion {
    /// Trace the camera paths of an image of aspect ratio `aspect` (width / height); `None`
    /// when the camera sees no surface that stores photons.
    pub fn new(ctx: &Context, aspect: f32, seed: u64) -> Option<ReadRegion> {
        let width = READ_PATHS_ACROSS;
        let height = ((width as f32 / aspect.max(1e-3)).round() as u32).clamp(1, 4 * width);
        let camera = CameraRays::new(&ctx.scene.camera, width, height);
        let rows: Vec<Vec<(Vec3, Vec3, bool)>> = (0..height)
            .into_par_iter()
            .map(|y| {
                let mut rng = Rng::for_item(seed ^ 0x6ead_5e91, y as u64, 0);
                let mut hits = Vec::new();
                for x in 0..width {
                    let film = Vec2::new(x as f32, y as f32) + rng.uniform2();
                    camera_path(ctx, camera.ray(film), &mut rng, &mut hits);
                }
                hits
            })
            .collect();
        let hits: Vec<(Vec3, Vec3, bool)> = rows.concat();
        let mut seen = Bounds::EMPTY;
        for &(p, _, first) in &hits {
            if first {
                seen.grow(p);
            }
        }
        if seen.is_empty() {
            return None;
        }
        let margin = Vec3::splat(READ_MARGIN * seen.diagonal().max(1e-6));
        let (lo, hi) = (seen.min - margin, seen.max + margin);
        let cell = (hi - lo).max_element() / READ_CELLS;
        let dims = ((hi - lo) / cell)
            .ceil()
            .as_uvec3()
            .to_array()
            .map(|d| d as usize + 1);
        let mut region = ReadRegion {
            lo,
            inv_cell: 1.0 / cell,
            dims,
            sides: vec![0; dims[0] * dims[1] * dims[2]],
        };
        for &(p, n, _) in &hits {
            region.mark(p, sides_near(n));
        }
        Some(region)
    }

    fn cell(&self, p: Vec3) -> Option<[usize; 3]> {
        let c = (p - self.lo) * self.inv_cell;
        let cell = [c.x, c.y, c.z];
        let mut out = [0usize; 3];
        for axis in 0..3 {
            if !(cell[axis] >= 0.0 && cell[axis] < self.dims[axis] as f32) {
                return None;
            }
            out[axis] = cell[axis] as usize;
        }
        Some(out)
    }

    fn index(&self, c: [usize; 3]) -> usize {
        (c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]
    }

    /// Mark `bits` in the cell of `p` and its 26 neighbours (camera paths sample surfaces
    /// sparsely; the render reads between them).
    fn mark(&mut self, p: Vec3, bits: u8) {
        let Some(c) = self.cell(p) else { return };
        for dz in 0..3 {
            for dy in 0..3 {
                for dx in 0..3 {
                    let n = [c[0] + dx, c[1] + dy, c[2] + dz];
                    if (0..3).all(|a| n[a] >= 1 && n[a] - 1 < self.dims[a]) {
                        let i = self.index([n[0] - 1, n[1] - 1, n[2] - 1]);
                        self.sides[i] |= bits;
                    }
                }
            }
        }
    }

    /// Whether the render reads photons stored at `p` on the side facing `n`.
    pub fn contains(&self, p: Vec3, n: Vec3) -> bool {
        self.cell(p)
            .is_some_and(|c| self.sides[self.index(c)] & (1 << side_of(n)) != 0)
    }
}

/// Follow one camera path by BSDF sampling, pushing (point, normal on the viewer's side, first)
/// for each of its first `READ_HITS` hits on surfaces that store photons.
fn camera_path(ctx: &Context, mut ray: Ray, rng: &mut Rng, out: &mut Vec<(Vec3, Vec3, bool)>) {
    let mut marked = 0;
    for bounce in 0..2 * READ_HITS + 2 {
        let visibility = if bounce == 0 {
            Visibility::Camera
        } else {
            Visibility::Secondary
        };
        let Some(hit) = ctx.accel.intersect(ctx.scene, &ray, visibility) else {
            return;
        };
        let s = Shading::new(ctx, &ray, &hit, bounce == 0);
        if stores_photons(&s.bsdf) {
            out.push((s.sh.p, s.ng, marked == 0));
            marked += 1;
            if marked == READ_HITS {
                return;
            }
        }
        let Some((_, wi)) = s.sample(rng.uniform(), rng.uniform2()) else {
            return;
        };
        ray = s.sh.spawn(wi);
    }
}

/// Where one light's photons are placed in its unit squares: an outer grid over the second
/// square (the world's direction; one cell for other lights) and, per outer cell, a grid over
/// the first square (position or direction).
struct LightGuide {
    outer: Distribution2D,
    outer_res: usize,
    inner: Vec<Distribution2D>,
}

impl LightGuide {
    /// `(u1, u2)` warped to the guide's density, and that density per unit area of the two
    /// squares.
    fn sample(&self, u1: Vec2, u2: Vec2) -> Option<(Vec2, Vec2, f32)> {
        let (v2, p_outer) = self.outer.sample(u2)?;
        let res = self.outer_res;
        let col = ((v2.x * res as f32) as usize).min(res - 1);
        let row = ((v2.y * res as f32) as usize).min(res - 1);
        let (v1, p_inner) = self.inner[row * res + col].sample(u1)?;
        let density = p_outer * p_inner;
        (density > 0.0 && density.is_finite()).then_some((v1, v2, density))
    }
}

/// The guides of the lights worth guiding (module header), by light index.
pub struct EmissionGuide {
    lights: Vec<Option<LightGuide>>,
}

/// Cells across the outer and the inner square for a light, or `None` for lights not guided.
fn grid_for(source: &LightSource) -> Option<(usize, usize)> {
    match source {
        LightSource::Sun { .. } | LightSource::Point { .. } => Some((1, 32)),
        LightSource::Spot { .. } => Some((1, 16)),
        LightSource::World { .. } => Some((8, 8)),
        LightSource::Triangle { .. } | LightSource::Instance { .. } => None,
    }
}

impl EmissionGuide {
    /// Pilot the lights against `region`; `None` when no light gains from it. `shares` is each
    /// light's share of the photons; `trace(light, u1, u2, rng, out)` emits one photon of
    /// `light` placed by the unit-square points `u1`, `u2` (uniform emission) and walks it,
    /// pushing (point, normal, luminance of the power) for each hit that stores it.
    pub fn new(
        ctx: &Context,
        region: &ReadRegion,
        shares: &[f32],
        seed: u64,
        trace: impl Fn(usize, Vec2, Vec2, &mut Rng, &mut Vec<(Vec3, Vec3, f32)>) + Sync,
    ) -> Option<EmissionGuide> {
        let sources = &ctx.lights.sources;
        // The brightest guidable lights: the pilots' cost stays bounded in scenes of many lamps.
        let mut order: Vec<usize> = (0..sources.len())
            .filter(|&i| grid_for(&sources[i]).is_some())
            .collect();
        order.sort_by(|&a, &b| shares[b].total_cmp(&shares[a]));
        order.truncate(MAX_GUIDED_LIGHTS);
        let lights: Vec<Option<LightGuide>> = (0..sources.len())
            .map(|light| {
                if !order.contains(&light) {
                    return None;
                }
                let (outer_res, inner_res) = grid_for(&sources[light])?;
                let pilot = Pilot {
                    region,
                    light,
                    outer_res,
                    inner_res,
                    seed,
                };
                pilot.guide(&trace)
            })
            .collect();
        lights
            .iter()
            .any(Option::is_some)
            .then_some(EmissionGuide { lights })
    }

    /// Warp light `light`'s squares; `None` when the light is emitted uniformly.
    pub fn sample(&self, light: usize, u1: Vec2, u2: Vec2) -> Option<Option<(Vec2, Vec2, f32)>> {
        self.lights
            .get(light)
            .and_then(Option::as_ref)
            .map(|g| g.sample(u1, u2))
    }
}

/// The pilot of one light: its grids and the region its photons should reach.
struct Pilot<'a> {
    region: &'a ReadRegion,
    light: usize,
    outer_res: usize,
    inner_res: usize,
    seed: u64,
}

impl Pilot<'_> {
    /// Trace the pilot photons (`EmissionGuide::new`'s `trace`) and weigh each cell by the
    /// power its photons store in the read region; `None` when guiding would gain little.
    fn guide(
        &self,
        trace: &(impl Fn(usize, Vec2, Vec2, &mut Rng, &mut Vec<(Vec3, Vec3, f32)>) + Sync),
    ) -> Option<LightGuide> {
        let (outer_res, inner_res) = (self.outer_res, self.inner_res);
        let (outer_cells, inner_cells) = (outer_res * outer_res, inner_res * inner_res);
        let cells = outer_cells * inner_cells;
        let per_cell = (PILOT_PHOTONS as usize / cells).max(2);
        let cell_point = |index: usize, res: usize, u: Vec2| {
            Vec2::new(
                ((index % res) as f32 + u.x) / res as f32,
                ((index / res) as f32 + u.y) / res as f32,
            )
        };
        let measured: Vec<(f64, f64)> = (0..cells)
            .into_par_iter()
            .map(|cell| {
                let mut rng =
                    Rng::for_item(self.seed ^ 0x9d1e_e7a3, self.light as u64, cell as u64);
                let (outer, inner) = (cell / inner_cells, cell % inner_cells);
                let (mut useful, mut stored) = (0.0f64, 0.0f64);
                let mut hits = Vec::new();
                for _ in 0..per_cell {
                    let u1 = cell_point(inner, inner_res, rng.uniform2());
                    let u2 = cell_point(outer, outer_res, rng.uniform2());
                    hits.clear();
                    trace(self.light, u1, u2, &mut rng, &mut hits);
                    for &(p, n, y) in &hits {
                        stored += y as f64;
                        if self.region.contains(p, n) {
                            useful += y as f64;
                        }
                    }
                }
                (useful, stored)
            })
            .collect();
        let useful: f64 = measured.iter().map(|m| m.0).sum();
        let stored: f64 = measured.iter().map(|m| m.1).sum();
        if !(useful > 0.0) || useful >= MAX_USEFUL_SHARE as f64 * stored {
            return None;
        }
        // Density per cell relative to uniform: the defensive mixture of the module header.
        let alpha = UNIFORM_SHARE as f64;
        let weight: Vec<f32> = measured
            .iter()
            .map(|&(u, _)| ((1.0 - alpha) * u / useful * cells as f64 + alpha) as f32)
            .collect();
        let inner: Vec<Distribution2D> = weight
            .chunks(inner_cells)
            .map(|w| Distribution2D::new(w, inner_res, inner_res))
            .collect();
        let outer_weight: Vec<f32> = weight.chunks(inner_cells).map(|w| w.iter().sum()).collect();
        Some(LightGuide {
            outer: Distribution2D::new(&outer_weight, outer_res, outer_res),
            outer_res,
            inner,
        })
    }
}
