//! Ward's irradiance cache (Ward, Rubinstein and Clear 1988, "A Ray Tracing Solution for Diffuse
//! Interreflection") with Ward and Heckbert's gradients (1992, "Irradiance Gradients"), as
//! Jensen's course notes (2000) present them. Depends only on math: the caller supplies the
//! radiance arriving along a direction through a closure, so the cache is tested on its own.
//!
//! **Records**: position xᵢ, normal Nᵢ, irradiance Eᵢ (RGB), the harmonic-mean distance Rᵢ to
//! the surfaces the gather rays hit, and per colour channel a rotation and a translation
//! gradient. Rᵢ is also held below twice the nearest hit distance: the harmonic mean lets a
//! record on a box face reach the floor it stands on, across the non-linear drop where the
//! face starts to see the box's own shadow (docs/bench/photon_method.md, "Record radii"). Hits
//! on a surface facing within ~26° of the record's normal do not count as nearest: on a concave
//! curved surface (the inside of a sphere or a cove) grazing rays meet the same surface at
//! distances going to zero, where irradiance changes smoothly, and would only add records. Eᵢ
//! comes from stratified cosine sampling on T × P cells, θ_t = asin(√((t − ξ)/T)),
//! φ_p = 2π(p − ψ)/P, E ≈ π/(TP) Σ L (every cell has projected solid angle π/(TP));
//! T ≈ √(N/π) and P = ⌈N/T⌉ from one "gather rays" setting N.
//!
//! **Gradients** from the same samples, radiance taken as constant over each cell:
//! - rotation: ∇_r = ∫ L (Nᵢ × ω) dω, summed cell by cell with the exact integral of sin θ over
//!   the cell (so no tan θ blows up near the horizon);
//! - translation (Ward & Heckbert): moving x along the tangent plane moves each wall between two
//!   cells at a rate 1/R of the nearer of the two surfaces seen; the gain is the radiance
//!   difference times the projected solid angle swept: walls of constant θ contribute
//!   sin θ cos² θ (L_{t,p} − L_{t−1,p}) / R · ∫_cell (cos φ, sin φ) dφ, walls of constant φ
//!   contribute (sin θ₊ − sin θ₋)(L_{t,p} − L_{t,p−1}) / R along the wall's normal direction.
//!
//! **Interpolation**: E(x) = Σ wᵢ (Eᵢ + (Nᵢ × N)·∇_r + (x − xᵢ)·∇_t) / Σ wᵢ over records with
//! w = 1/(‖x−xᵢ‖/Rᵢ + √(1−N·Nᵢ)) > 1/a, a the accuracy; records in front of x
//! ((x − xᵢ)·(N + Nᵢ)/2 < 0, with a small tolerance) are skipped. The sums use w − 1/a, which
//! falls to zero at the edge of a record's validity, so coverage boundaries leave no seams. Rᵢ is clamped so that a record
//! covers between `min_spacing` and `max_spacing` pixels (a·Rᵢ in pixel footprints at xᵢ),
//! and at most `MAX_FRAME_SHARE` of the frame's larger side: this stops record explosions in
//! corners and splotches from far-seeing records, at any image size.
//!
//! **Spatial index**: a loose octree; a record lives in the deepest node at least as large as its
//! validity radius a·Rᵢ. Each node also keeps the box bounding the validity spheres of its
//! subtree's records, and a lookup visits only the nodes whose box holds x, testing each record's
//! sphere before reading the record.
//!
//! **Determinism with threads** (`build`): records are placed in a pre-pass over a coarse-to-fine
//! pixel pattern (every 32nd pixel, then every 16th, ... every pixel). The candidates of a level
//! are tested in parallel against the read-only cache of the previous levels; uncovered ones
//! compute a record from their own random stream; the new records are inserted in pixel order.
//! A ray budget (`max_rays_per_pixel`) is checked per level, on the count of uncovered
//! candidates before any of them gathers: the cache holds whole levels only.
//! Rendering then only reads the cache. A shading point no record covers returns `None`, and the
//! integrator computes that point without the cache (plain final gather or path tracing) and
//! stores nothing, so the image never depends on thread timing.

use crate::error::{Error, Result};
use crate::math::{Frame, Vec3};
use crate::rng::Rng;
use rayon::prelude::*;
use std::f32::consts::PI;

/// Irradiance-cache settings; the command line maps onto them.
#[derive(Clone, Debug, PartialEq)]
pub struct IcSettings {
    /// The photon method shades Lambertian surfaces from the cache (`--irradiance-cache`).
    pub enabled: bool,
    /// Ward's accuracy a: records are used where w > 1/a (default 0.2).
    pub accuracy: f32,
    /// Gather rays per record, split into T × P strata (default 256).
    pub gather_rays: u32,
    /// Smallest radius a record covers, in pixels (default 3: in corners, where Ward's Rᵢ goes
    /// to zero, closer records cost more for no lower error; docs/bench/photon_method.md,
    /// "Record radii").
    pub min_spacing: f32,
    /// Largest radius a record covers, in pixels (default 48; `build` lowers it on frames
    /// under 640 pixels, `MAX_FRAME_SHARE`).
    pub max_spacing: f32,
    /// Gather rays per pixel of the frame the whole cache may cost; the build stops before a
    /// level whose new records would pass it, and points no record covers are shaded without
    /// the cache (`None`: no limit).
    pub max_rays_per_pixel: Option<f32>,
}

impl Default for IcSettings {
    fn default() -> Self {
        IcSettings {
            enabled: true,
            accuracy: 0.2,
            gather_rays: 256,
            min_spacing: 3.0,
            max_spacing: 48.0,
            max_rays_per_pixel: None,
        }
    }
}

impl IcSettings {
    /// Reject settings that cannot work, naming the flag.
    pub fn validate(&self) -> Result<()> {
        if !(self.accuracy.is_finite() && self.accuracy > 0.0 && self.accuracy <= 1.0) {
            return Err(Error::Settings(format!(
                "--ic-accuracy must be in (0, 1], not {}",
                self.accuracy
            )));
        }
        if self.gather_rays == 0 {
            return Err(Error::Settings(
                "--ic-gather-rays must be at least 1".into(),
            ));
        }
        let (lo, hi) = (self.min_spacing, self.max_spacing);
        if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= hi) {
            return Err(Error::Settings(format!(
                "--ic-min-spacing ({lo}) and --ic-max-spacing ({hi}) must be positive with min <= max"
            )));
        }
        if let Some(budget) = self.max_rays_per_pixel {
            if !(budget >= 0.0) {
                return Err(Error::Settings(format!(
                    "--ic-ray-budget must be at least 0 rays per pixel, not {budget}"
                )));
            }
        }
        Ok(())
    }

    /// The T × P strata for the gather-ray budget: P ≈ πT (Ward's square-ish cells).
    pub fn strata(&self) -> (u32, u32) {
        let n = self.gather_rays.max(1);
        let t = ((n as f32 / PI).sqrt().round() as u32).max(1);
        (t, n.div_ceil(t))
    }
}

/// What a gather ray brings back.
#[derive(Clone, Copy, Debug)]
pub struct Incoming {
    pub radiance: Vec3,
    /// Distance to the surface the radiance came from (infinite for none).
    pub distance: f32,
    /// That surface's unit normal, on either side (zero for none: counts as an obstacle).
    pub normal: Vec3,
}

impl Incoming {
    /// Nothing hit: no radiance from anything at a finite distance.
    pub const NONE: Incoming = Incoming {
        radiance: Vec3::ZERO,
        distance: f32::INFINITY,
        normal: Vec3::ZERO,
    };
}

/// Cosine above which a gather hit's surface faces the record's way closely enough to count as
/// the same (curved) surface, not as a nearby obstacle, for the bound Rᵢ ≤ 2 d_min.
const SAME_SURFACE_COS: f32 = 0.9;

/// Where a record may be placed: a surface point seen through a pixel.
#[derive(Clone, Copy, Debug)]
pub struct Site {
    pub p: Vec3,
    /// Unit normal on the side the irradiance arrives from.
    pub n: Vec3,
    /// World size of one pixel at `p` (along the camera path).
    pub footprint: f32,
}

/// One irradiance record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Record {
    pub p: Vec3,
    pub n: Vec3,
    pub e: Vec3,
    /// Harmonic-mean distance, clamped by the spacing limits.
    pub r: f32,
    /// Rotation gradient per colour channel: dE_c = ∇_r[c] · (rotation vector).
    pub grad_r: [Vec3; 3],
    /// Translation gradient per colour channel (in the tangent plane).
    pub grad_t: [Vec3; 3],
    /// World size of a pixel at `p` (for the record-position view).
    pub footprint: f32,
}

fn channels(v: Vec3, dir: Vec3) -> [Vec3; 3] {
    [dir * v.x, dir * v.y, dir * v.z]
}

fn add3(a: &mut [Vec3; 3], b: [Vec3; 3]) {
    for (x, y) in a.iter_mut().zip(b) {
        *x += y;
    }
}

/// Gather a record at `site`: `gather(direction, rng)` returns what arrives along the world
/// direction (radiance, distance and normal of the surface it came from). Distances
/// below the minimum spacing's radius count as that radius, in Rᵢ and in the translation
/// gradient (a wall met at distance ~0 in a corner would make the gradient explode); `build`
/// clamps Rᵢ from above.
pub fn gather_record(
    site: &Site,
    settings: &IcSettings,
    rng: &mut Rng,
    mut gather: impl FnMut(Vec3, &mut Rng) -> Incoming,
) -> Record {
    let (nt, np) = settings.strata();
    let (tf, pf) = (nt as f32, np as f32);
    let frame = Frame::from_normal(site.n);
    let mut l = Vec::with_capacity((nt * np) as usize);
    let mut d = Vec::with_capacity((nt * np) as usize);
    let mut inv_d = 0.0f32;
    // Nearest hit, for the bound on Rᵢ (module header).
    let mut d_min = f32::INFINITY;
    let r_min = settings.min_spacing * site.footprint / settings.accuracy;
    for t in 0..nt {
        for p in 0..np {
            let u = rng.uniform2();
            let sin2 = (t as f32 + u.x) / tf;
            let (sin_t, cos_t) = (sin2.sqrt(), (1.0 - sin2).max(0.0).sqrt());
            let phi = 2.0 * PI * (p as f32 + u.y) / pf;
            let local = Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t);
            let dir = frame.to_world(local);
            let incoming = gather(dir, rng);
            let (li, di) = (incoming.radiance, incoming.distance);
            let li = if li.is_finite() {
                li.max(Vec3::ZERO)
            } else {
                Vec3::ZERO
            };
            let di = if di > 0.0 {
                di.max(r_min)
            } else {
                f32::INFINITY
            };
            inv_d += 1.0 / di;
            // The hit surface's normal on the side facing the record.
            let facing = incoming.normal * -incoming.normal.dot(dir).signum();
            if facing.dot(site.n) < SAME_SURFACE_COS {
                d_min = d_min.min(di);
            }
            l.push(li);
            d.push(di);
        }
    }
    let at = |t: u32, p: u32| (t * np + p % np) as usize;
    // Cell boundaries: sin θ at the t-th wall, and ∫ (cos φ, sin φ) dφ over cell p.
    let sin_wall = |t: u32| (t as f32 / tf).sqrt();
    let theta_wall = |t: u32| sin_wall(t).min(1.0).asin();
    let phi_wall = |p: u32| 2.0 * PI * p as f32 / pf;
    let u_cell = |p: u32| {
        let (a, b) = (phi_wall(p), phi_wall(p + 1));
        Vec3::new(b.sin() - a.sin(), a.cos() - b.cos(), 0.0)
    };
    let mut e = Vec3::ZERO;
    let mut grad_r = [Vec3::ZERO; 3];
    let mut grad_t = [Vec3::ZERO; 3];
    for t in 0..nt {
        // ∫ sin²θ dθ over the θ cell (rotation), sin θ and cos²θ at its upper wall (translation).
        let (t0, t1) = (theta_wall(t), theta_wall(t + 1));
        let sin2_int = 0.5 * (t1 - t0) - 0.25 * ((2.0 * t1).sin() - (2.0 * t0).sin());
        let s = sin_wall(t);
        let wall_t = s * (1.0 - s * s);
        let wall_p = sin_wall(t + 1) - s;
        for p in 0..np {
            let li = l[at(t, p)];
            e += li;
            // ∫ (−sin φ, cos φ) dφ = ∫ (cos φ, sin φ) dφ rotated by 90° in the plane.
            let uc = u_cell(p);
            add3(
                &mut grad_r,
                channels(li * sin2_int, Vec3::new(-uc.y, uc.x, 0.0)),
            );
            if t > 0 {
                let r = d[at(t, p)].min(d[at(t - 1, p)]);
                let dl = (li - l[at(t - 1, p)]) * (wall_t / r);
                add3(&mut grad_t, channels(dl, uc));
            }
            // The wall at φ_p between cells p − 1 and p, moving along its normal v.
            let prev = (p + np - 1) % np;
            let r = d[at(t, p)].min(d[at(t, prev)]);
            let phi = phi_wall(p);
            let v = Vec3::new(-phi.sin(), phi.cos(), 0.0);
            add3(
                &mut grad_t,
                channels((li - l[at(t, prev)]) * (wall_p / r), v),
            );
        }
    }
    let n = (nt * np) as f32;
    // A degenerate footprint can leave distances tiny enough to overflow the gradient.
    let to_world = |g: [Vec3; 3]| {
        g.map(|v| {
            let w = frame.to_world(v);
            if w.is_finite() {
                w
            } else {
                Vec3::ZERO
            }
        })
    };
    Record {
        p: site.p,
        n: site.n,
        e: e * (PI / n),
        r: if inv_d > 0.0 {
            (n / inv_d).min(2.0 * d_min)
        } else {
            f32::INFINITY
        },
        grad_r: to_world(grad_r),
        grad_t: to_world(grad_t),
        footprint: site.footprint,
    }
}

/// Octree node: a cube of half-size `half` around `center`; `children[i]` is 0 when absent.
/// `reach_min`/`reach_max` bound the validity spheres of every record in the node's subtree: a
/// lookup enters only the nodes whose reach holds its point, which is much tighter than the loose
/// box (records lie on surfaces, so a node's reach is thin across a flat wall).
#[derive(Clone, Debug)]
struct Node {
    center: Vec3,
    half: f32,
    children: [u32; 8],
    records: Vec<Extent>,
    reach_min: Vec3,
    reach_max: Vec3,
}

/// Where a record of a node is valid: its position and squared validity radius (a·Rᵢ)², kept
/// next to each other so that a lookup rejects the records it is outside of (most of those in a
/// loose node) without reading the full record.
#[derive(Clone, Copy, Debug)]
struct Extent {
    p: Vec3,
    radius2: f32,
    index: u32,
}

impl Node {
    fn new(center: Vec3, half: f32) -> Node {
        Node {
            center,
            half,
            children: [0; 8],
            records: Vec::new(),
            reach_min: Vec3::INFINITY,
            reach_max: Vec3::NEG_INFINITY,
        }
    }
}

/// Deepest octree level (keeps degenerate radii from recursing forever).
const MAX_DEPTH: u32 = 24;

/// The records and their loose octree.
#[derive(Clone, Debug)]
pub struct IrradianceCache {
    records: Vec<Record>,
    nodes: Vec<Node>,
    accuracy: f32,
    /// Use the gradients when interpolating (on by default; off for comparisons).
    pub gradients: bool,
}

impl IrradianceCache {
    /// An empty cache over the cube of half-size `half` around `center` (records outside it
    /// still work: they stay in the root).
    pub fn new(center: Vec3, half: f32, accuracy: f32) -> Self {
        IrradianceCache {
            records: Vec::new(),
            nodes: vec![Node::new(center, half.max(1e-6))],
            accuracy,
            gradients: true,
        }
    }

    pub fn records(&self) -> &[Record] {
        &self.records
    }

    pub fn len(&self) -> usize {
        self.records.len()
    }

    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }

    /// Add a record (its `r` already clamped).
    pub fn insert(&mut self, record: Record) {
        let radius = self.accuracy * record.r;
        let index = self.records.len() as u32;
        self.records.push(record);
        // The validity radius widened by a relative 1e-5, so that the tests of `visit` never
        // drop through rounding a record that `error` accepts.
        let reach = radius * (1.0 + 1e-5);
        let (lo, hi) = (record.p - Vec3::splat(reach), record.p + Vec3::splat(reach));
        let mut node = 0usize;
        for _ in 0..MAX_DEPTH {
            let n = &mut self.nodes[node];
            n.reach_min = n.reach_min.min(lo);
            n.reach_max = n.reach_max.max(hi);
            let (c, half) = (n.center, n.half);
            // A child's loose box reaches half a child beyond it: it holds spheres of radius ≤ half/2.
            let inside = (record.p - c).abs().max_element() <= half;
            if !(radius <= 0.5 * half && inside) {
                break;
            }
            let octant = (record.p.x > c.x) as usize
                | (((record.p.y > c.y) as usize) << 1)
                | (((record.p.z > c.z) as usize) << 2);
            let child = self.nodes[node].children[octant] as usize;
            node = if child != 0 {
                child
            } else {
                let sign = |bit: usize| if octant & bit != 0 { 0.5 } else { -0.5 };
                let offset = Vec3::new(sign(1), sign(2), sign(4)) * half;
                self.nodes.push(Node::new(c + offset, 0.5 * half));
                let new = self.nodes.len() - 1;
                self.nodes[node].children[octant] = new as u32;
                new
            };
        }
        let n = &mut self.nodes[node];
        n.reach_min = n.reach_min.min(lo);
        n.reach_max = n.reach_max.max(hi);
        n.records.push(Extent {
            p: record.p,
            radius2: reach * reach,
            index,
        });
    }

    /// Call `f` with every record whose (slightly widened) validity sphere holds `p`.
    fn visit(&self, p: Vec3, mut f: impl FnMut(&Record)) {
        self.visit_until(p, |rec| {
            f(rec);
            false
        });
    }

    /// Call `f` with the records whose (slightly widened) validity sphere holds `p` until it
    /// returns true; whether it did.
    fn visit_until(&self, p: Vec3, mut f: impl FnMut(&Record) -> bool) -> bool {
        // Depth-first with a fixed stack: at most 8 children wait per level.
        let mut stack = [0u32; 8 * MAX_DEPTH as usize + 1];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            for e in &node.records {
                if (p - e.p).length_squared() <= e.radius2 && f(&self.records[e.index as usize]) {
                    return true;
                }
            }
            for &c in &node.children {
                if c != 0 {
                    let child = &self.nodes[c as usize];
                    if p.cmpge(child.reach_min).all() && p.cmple(child.reach_max).all() {
                        stack[top] = c;
                        top += 1;
                    }
                }
            }
        }
        false
    }

    /// Ward's error estimate εᵢ(x) = ‖x−xᵢ‖/Rᵢ + √(1−N·Nᵢ), or `None` when record is unusable
    /// at (p, n): beyond the accuracy or in front of p.
    fn error(&self, rec: &Record, p: Vec3, n: Vec3) -> Option<f32> {
        let d = p - rec.p;
        let eps = d.length() / rec.r + (1.0 - n.dot(rec.n)).max(0.0).sqrt();
        let in_front = 0.5 * d.dot(n + rec.n) < -0.05 * self.accuracy * rec.r;
        (eps < self.accuracy && !in_front).then_some(eps)
    }

    /// Interpolated irradiance at `p` with unit normal `n`, or `None` when no record is valid.
    pub fn lookup(&self, p: Vec3, n: Vec3) -> Option<Vec3> {
        let mut sum = Vec3::ZERO;
        let mut weights = 0.0f32;
        self.visit(p, |rec| {
            let Some(eps) = self.error(rec, p, n) else {
                return;
            };
            let w = 1.0 / eps.max(1e-6) - 1.0 / self.accuracy;
            let mut e = rec.e;
            if self.gradients {
                let rot = rec.n.cross(n);
                let d = p - rec.p;
                for c in 0..3 {
                    e[c] += rot.dot(rec.grad_r[c]) + d.dot(rec.grad_t[c]);
                }
            }
            sum += w * e.max(Vec3::ZERO);
            weights += w;
        });
        (weights > 0.0).then(|| sum / weights)
    }

    /// Whether some record is valid at (p, n): `lookup` would answer.
    pub fn covers(&self, p: Vec3, n: Vec3) -> bool {
        self.visit_until(p, |rec| self.error(rec, p, n).is_some())
    }

    /// True when a record lies within one pixel footprint (and its validity radius) of `p`
    /// with a similar normal: the record-position view.
    pub fn near_record(&self, p: Vec3, n: Vec3) -> bool {
        let mut found = false;
        self.visit(p, |rec| {
            let radius = rec.footprint.min(self.accuracy * rec.r);
            found |= rec.n.dot(n) > 0.9 && (p - rec.p).length_squared() < radius * radius;
        });
        found
    }
}

/// What `build` did.
#[derive(Clone, Debug, Default)]
pub struct BuildInfo {
    pub records: usize,
    pub levels: u32,
    /// Candidate pixels examined over all levels.
    pub candidates: usize,
    /// The build stopped early at `max_rays_per_pixel`.
    pub budget_reached: bool,
}

/// Clamp a record's Rᵢ so that it covers between the minimum and maximum spacing in pixels, and
/// (Tabellion & Lamorlette 2004) so that the translation gradient changes no channel by more than
/// its value over Rᵢ: Rᵢ ≤ E_c / |∇_t E_c|.
fn clamp_radius(rec: &mut Record, settings: &IcSettings) {
    let per_pixel = rec.footprint / settings.accuracy;
    let (lo, hi) = (
        settings.min_spacing * per_pixel,
        settings.max_spacing * per_pixel,
    );
    let mut r = if rec.r.is_nan() { hi } else { rec.r.min(hi) };
    for c in 0..3 {
        let g = rec.grad_t[c].length();
        if g > 0.0 {
            r = r.min(rec.e[c] / g);
        }
    }
    rec.r = r.max(lo);
    // Where the minimum spacing wins, shorten the gradient instead, to the same bound.
    for c in 0..3 {
        let change = rec.grad_t[c].length() * rec.r;
        if change > rec.e[c] {
            rec.grad_t[c] *= rec.e[c] / change;
        }
    }
}

/// Largest radius a record covers as a share of the frame's larger side: 48 pixels of a
/// 640-pixel frame. A record whose rays missed small, distant geometry sees nothing near and
/// reaches as far as it may; on a 48-pixel render the 48-pixel bound let one such record cover
/// the frame, and the glass cube's floor, lit only through the cube, got half its indirect
/// light (docs/bench/photon_method.md, "The irradiance cache on an open floor").
const MAX_FRAME_SHARE: f32 = 0.075;

/// Place records over a `width` × `height` image, coarse to fine (see the module header).
/// `find(x, y, rng)` returns the site seen through pixel (x, y) with the caller's surface data
/// `P`, `gather(data, direction, rng)` the radiance along a direction and its distance;
/// `check` is called before each level and at the end, and stops the build on error
/// (cancellation; `find` may return `None` and `gather` `Incoming::NONE` meanwhile to finish a
/// level quickly).
#[allow(clippy::too_many_arguments)]
pub fn build<P: Send>(
    width: u32,
    height: u32,
    settings: &IcSettings,
    seed: u64,
    bounds: (Vec3, f32),
    find: impl Fn(u32, u32, &mut Rng) -> Option<(Site, P)> + Sync,
    gather: impl Fn(&P, Vec3, &mut Rng) -> Incoming + Sync,
    check: impl Fn(f32) -> Result<()>,
) -> Result<(IrradianceCache, BuildInfo)> {
    settings.validate()?;
    let frame_bound = MAX_FRAME_SHARE * width.max(height) as f32;
    let settings = &IcSettings {
        max_spacing: settings
            .max_spacing
            .min(frame_bound)
            .max(settings.min_spacing),
        ..settings.clone()
    };
    let mut cache = IrradianceCache::new(bounds.0, bounds.1, settings.accuracy);
    let mut info = BuildInfo::default();
    let mut step = 32u32;
    while step > 1 && step >= width.max(height) {
        step /= 2;
    }
    let levels = step.trailing_zeros() + 1;
    let budget = settings
        .max_rays_per_pixel
        .map_or(f64::INFINITY, |r| r as f64 * width as f64 * height as f64);
    let (t, p) = settings.strata();
    let rays_per_record = (t * p) as f64;
    let mut rays_spent = 0.0;
    loop {
        check(info.levels as f32 / levels as f32)?;
        let (nx, ny) = (width.div_ceil(step), height.div_ceil(step));
        let cache_ref = &cache;
        // The level's uncovered sites first, so that its cost is known before any ray is
        // gathered; each keeps its random stream for the gather. A pixel of the level before
        // finds the same site again (its stream is the pixel's), covered since: skipped.
        let coarser = 2 * step;
        let first_level = info.levels == 0;
        let sites: Vec<(Site, P, Rng)> = (0..nx * ny)
            .into_par_iter()
            .filter_map(|i| {
                let (x, y) = (i % nx * step, i / nx * step);
                if !first_level && x % coarser == 0 && y % coarser == 0 {
                    return None;
                }
                let mut rng = Rng::for_item(seed ^ 0x1c_ca5e, (y * width + x) as u64, 0);
                let (site, data) = find(x, y, &mut rng)?;
                let covered = cache_ref.covers(site.p, site.n);
                (!covered).then_some((site, data, rng))
            })
            .collect();
        info.candidates += (nx * ny) as usize;
        let cost = sites.len() as f64 * rays_per_record;
        if rays_spent + cost > budget {
            info.budget_reached = true;
            break;
        }
        rays_spent += cost;
        let new: Vec<Record> = sites
            .into_par_iter()
            .map(|(site, data, mut rng)| {
                let mut rec = gather_record(&site, settings, &mut rng, |dir, rng| {
                    gather(&data, dir, rng)
                });
                clamp_radius(&mut rec, settings);
                rec
            })
            .collect();
        info.levels += 1;
        for rec in new {
            cache.insert(rec);
        }
        if step == 1 {
            break;
        }
        step /= 2;
    }
    check(1.0)?;
    info.records = cache.len();
    Ok((cache, info))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(p: Vec3, r: f32) -> Record {
        Record {
            p,
            n: Vec3::Z,
            e: Vec3::ONE,
            r,
            grad_r: [Vec3::ZERO; 3],
            grad_t: [Vec3::ZERO; 3],
            footprint: 0.01,
        }
    }

    #[test]
    fn strata_follow_the_budget() {
        let s = |n| IcSettings {
            gather_rays: n,
            ..IcSettings::default()
        };
        assert_eq!(s(1).strata(), (1, 1));
        let (t, p) = s(512).strata();
        assert_eq!((t, p), (13, 40));
        assert!(t * p >= 512 && t * p < 512 + t);
    }

    #[test]
    fn constant_radiance_gives_pi_and_no_gradient() {
        let site = Site {
            p: Vec3::ZERO,
            n: Vec3::new(0.0, 0.6, 0.8),
            footprint: 1e-3,
        };
        let mut rng = Rng::new(3);
        let rec = gather_record(&site, &IcSettings::default(), &mut rng, |_, _| Incoming {
            radiance: Vec3::splat(2.0),
            distance: 4.0,
            normal: Vec3::ZERO,
        });
        assert!((rec.e - Vec3::splat(2.0 * PI)).abs().max_element() < 1e-3);
        assert!((rec.r - 4.0).abs() < 1e-3);
        for c in 0..3 {
            assert!(rec.grad_t[c].length() < 1e-4, "{:?}", rec.grad_t);
            assert!(rec.grad_r[c].length() < 1e-3, "{:?}", rec.grad_r);
        }
    }

    #[test]
    fn lookup_respects_accuracy_normals_and_the_front_test() {
        let mut cache = IrradianceCache::new(Vec3::ZERO, 10.0, 0.2);
        for i in 0..50 {
            cache.insert(record(
                Vec3::new(i as f32 * 0.3 - 7.0, 0.0, 0.0),
                0.5 + i as f32 * 0.01,
            ));
        }
        cache.insert(record(Vec3::new(3.0, 3.0, 0.0), 1.0));
        // Within a·R = 0.2 of the lonely record, with the same normal.
        assert!(cache.lookup(Vec3::new(3.15, 3.0, 0.0), Vec3::Z).is_some());
        assert!(cache.lookup(Vec3::new(3.25, 3.0, 0.0), Vec3::Z).is_none());
        // A normal tilted by 30°: √(1 − cos 30°) ≈ 0.37 > a.
        let tilted = Vec3::new(0.5, 0.0, 0.866);
        assert!(cache.lookup(Vec3::new(3.0, 3.0, 0.0), tilted).is_none());
        // Below the record (the record is in front of the point).
        assert!(cache.lookup(Vec3::new(3.0, 3.0, -0.1), Vec3::Z).is_none());
        // Matches a brute-force scan over all records.
        for i in 0..200 {
            let p = Vec3::new(i as f32 * 0.07 - 7.0, (i % 7) as f32 * 0.01, 0.0);
            let brute = cache
                .records()
                .iter()
                .any(|r| cache.error(r, p, Vec3::Z).is_some());
            assert_eq!(cache.lookup(p, Vec3::Z).is_some(), brute, "at {p}");
            assert_eq!(cache.covers(p, Vec3::Z), brute, "at {p}");
        }
    }

    #[test]
    fn bad_settings_are_rejected() {
        for s in [
            IcSettings {
                accuracy: 0.0,
                ..IcSettings::default()
            },
            IcSettings {
                gather_rays: 0,
                ..IcSettings::default()
            },
            IcSettings {
                min_spacing: 10.0,
                max_spacing: 2.0,
                ..IcSettings::default()
            },
        ] {
            assert!(s.validate().is_err());
        }
    }
}
