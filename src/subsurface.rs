//! Subsurface scattering by dipole diffusion (Jensen, Marschner, Levoy & Hanrahan 2001, "A
//! practical model for subsurface light transport", §2.4–2.5) evaluated over irradiance samples
//! with the hierarchical integration of Jensen & Buhler 2002 ("A rapid hierarchical rendering
//! technique for translucent materials", §3–4). Depends only on math, so it is tested alone.
//!
//! **Parameters** (Blender's Principled BSDF, our `PHOTON_material_subsurface` extension): the
//! base colour is the total diffuse reflectance R_d the surface must show, the mean free path
//! ℓ = radius × scale per channel is taken as the reduced mean free path 1/σ_t′, and the
//! subsurface IOR η gives the boundary term A = (1 + F_dr)/(1 − F_dr), with F_dr from Egan &
//! Hilgeman's fit (JMLH01 eq. 5). **Albedo inversion** (Jensen & Buhler §4): the reduced albedo
//! α′ is found by bisection so that the dipole's total diffuse reflectance
//! R_d(α′) = α′/2 (1 + e^{−(4/3) A √(3(1−α′))}) e^{−√(3(1−α′))} equals the base colour; it is
//! monotone in α′ and reaches 1 at α′ = 1, so any colour in [0, 1] is reachable. Then
//! σ_tr = √(3(1−α′))/ℓ, z_r = ℓ, z_v = z_r (1 + 4A/3). Anisotropy is carried but does not
//! enter: the colour and the reduced mean free path already fix the reduced coefficients.
//!
//! **Dipole** (JMLH01 eq. 4): R_d(r) = α′/4π [z_r(σ_tr d_r + 1) e^{−σ_tr d_r}/d_r³ +
//! z_v(σ_tr d_v + 1) e^{−σ_tr d_v}/d_v³], d = √(r² + z²). Its integral over a disc of radius R
//! has the closed form P(R) = α′/2 Σ_{z∈{z_r,z_v}} (e^{−σ_tr z} − z e^{−σ_tr d(R)}/d(R)), since
//! z(σd + 1)e^{−σd} r/d³ is −z d/dr(e^{−σd}/d); P(∞) is R_d(α′) above.
//!
//! **Kernel.** Samples are points carrying flux ΔΦ (photons: the flux that entered the
//! material). Summing R_d(r) ΔΦ misses R_d's peak when ℓ is smaller than the sample spacing, and
//! R_d(0) grows like 1/ℓ². So each sample's kernel is R_d(r) outside a radius h (about the
//! sample spacing, `SampleTree::smoothing`) and the disc mean P(h)/(πh²) inside: its integral is
//! still exactly R_d(α′) for any ℓ, it is finite, and as ℓ → 0 it becomes a box filter of radius
//! h with weight R_d: the diffuse limit. Exitance M(x) = Σ K(‖x − x_p‖) ΔΦ_p.
//!
//! **Hierarchy** (Jensen & Buhler §3): an octree over the samples; each node keeps its total
//! flux, its flux-weighted centre, its bounds and the area its samples represent (count × the
//! area per sample, or half its box's squared diagonal where that is larger: photon samples are
//! not spread evenly by area as Jensen & Buhler's points are). A node is used as one sample at its centre when the solid angle it
//! subtends, ΔΩ = area / ‖x − centre‖², is below `accuracy` and x is further than h from its
//! bounds; otherwise its children are visited. The node's value is the kernel's Taylor
//! expansion about its flux-weighted centre to second order (the centre alone reads low: R_d is
//! convex), which needs each node's weighted covariance of positions (a quadrupole term). `exitance_brute_force` sums every sample, for
//! tests.

use crate::math::Vec3;
use std::collections::HashMap;
use std::f32::consts::PI;
use std::sync::RwLock;

/// Samples per octree leaf.
const LEAF_SIZE: usize = 8;
/// Deepest octree level (coincident samples stop splitting here).
const MAX_DEPTH: u32 = 24;
/// Bisection steps of the albedo inversion (2⁻⁴⁸ resolution in α′).
const INVERSION_STEPS: u32 = 48;
/// e^{−x} for x beyond this is subnormal in f32 (below 2⁻¹²⁶ ≈ e^{−87.3}).
const EXP_UNDERFLOW: f32 = 87.0;
/// Shards of `ExitanceCache`'s map (each behind its own lock).
const CACHE_SHARDS: usize = 64;

/// Diffuse Fresnel reflectance F_dr for relative IOR `eta` (Egan & Hilgeman's fit, JMLH01
/// eq. 5), with `eta` clamped to [1, 4]: below 1 the fit is not meant for the inside of an
/// object lit from outside.
pub fn diffuse_fresnel_reflectance(eta: f32) -> f32 {
    let eta = if eta.is_finite() {
        eta.clamp(1.0, 4.0)
    } else {
        1.0
    };
    -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta
}

/// The boundary term A = (1 + F_dr)/(1 − F_dr).
pub fn boundary_term(eta: f32) -> f32 {
    let fdr = diffuse_fresnel_reflectance(eta);
    (1.0 + fdr) / (1.0 - fdr)
}

/// Total diffuse reflectance of the dipole for reduced albedo `alpha` and boundary term `a`
/// (JMLH01 eq. 5 integrated, their closed form).
pub fn total_reflectance(alpha: f32, a: f32) -> f32 {
    total_reflectance_f64(alpha as f64, a as f64) as f32
}

fn total_reflectance_f64(alpha: f64, a: f64) -> f64 {
    let alpha = alpha.clamp(0.0, 1.0);
    let s = (3.0 * (1.0 - alpha)).sqrt();
    0.5 * alpha * (1.0 + (-(4.0 / 3.0) * a * s).exp()) * (-s).exp()
}

/// The reduced albedo α′ whose total diffuse reflectance is `rd` (clamped to [0, 1]), by
/// bisection in f64 (R_d is steep near α′ = 1).
pub fn invert_albedo(rd: f32, a: f32) -> f32 {
    let rd = if rd.is_finite() {
        rd.clamp(0.0, 1.0) as f64
    } else {
        0.0
    };
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for _ in 0..INVERSION_STEPS {
        let mid = 0.5 * (lo + hi);
        if total_reflectance_f64(mid, a as f64) < rd {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (0.5 * (lo + hi)) as f32
}

/// One colour channel of the dipole.
#[derive(Clone, Copy, Debug)]
struct Channel {
    alpha: f32,
    sigma_tr: f32,
    zr: f32,
    zv: f32,
    /// Kernel value inside the smoothing radius: P(h)/(πh²).
    inner: f32,
}

impl Channel {
    fn new(rd: f32, mfp: f32, a: f32, h: f32) -> Channel {
        let alpha = invert_albedo(rd, a);
        let zr = mfp;
        let mut c = Channel {
            alpha,
            sigma_tr: (3.0 * (1.0 - alpha)).sqrt() / zr,
            zr,
            zv: zr * (1.0 + 4.0 / 3.0 * a),
            inner: 0.0,
        };
        c.inner = c.cumulative(h) / (PI * h * h);
        c
    }

    fn pole(&self, z: f32, r2: f32) -> f32 {
        let d = (r2 + z * z).sqrt();
        let s = self.sigma_tr * d;
        if s > EXP_UNDERFLOW {
            // e^{−s} is below f32's smallest normal: skip the slow subnormal path of `exp`.
            return 0.0;
        }
        z * (s + 1.0) * (-s).exp() / (d * d * d)
    }

    fn rd(&self, r2: f32) -> f32 {
        self.alpha / (4.0 * PI) * (self.pole(self.zr, r2) + self.pole(self.zv, r2))
    }

    /// One pole's f(d) = z(σd + 1)e^{−σd}/d³ at squared radius `r2`, as (f, f′/r, f″) with
    /// derivatives in r: f′(d) = −z e^{−σd}(σ²d² + 3σd + 3)/d⁴,
    /// f″(d) = z e^{−σd}(σ³d³ + 5σ²d² + 12σd + 12)/d⁵, and d = √(r² + z²).
    #[inline]
    fn pole_derivatives(&self, z: f32, r2: f32) -> [f32; 3] {
        let d2 = r2 + z * z;
        let d = d2.sqrt();
        let s = self.sigma_tr * d;
        if s > EXP_UNDERFLOW {
            return [0.0; 3];
        }
        let inv_d = d.recip();
        let inv_d2 = inv_d * inv_d;
        let g = z * (-s).exp() * inv_d2 * inv_d; // z e^{−σd}/d³
        let p2 = (s + 3.0) * s + 3.0;
        let p3 = ((s + 5.0) * s + 12.0) * s + 12.0;
        // d/dr = (r/d) d/dd; d²/dr² = (r/d)² d²/dd² + (z²/d³) d/dd.
        [
            g * (s + 1.0),
            -g * p2 * inv_d2,
            g * inv_d2 * inv_d2 * (p3 * r2 - p2 * z * z),
        ]
    }

    /// (R_d, R_d′/r, R_d″) at squared radius `r2`.
    fn rd_derivatives(&self, r2: f32) -> [f32; 3] {
        let (a, b) = (
            self.pole_derivatives(self.zr, r2),
            self.pole_derivatives(self.zv, r2),
        );
        let k = self.alpha / (4.0 * PI);
        [k * (a[0] + b[0]), k * (a[1] + b[1]), k * (a[2] + b[2])]
    }

    /// P(radius), in f64: the two terms of each pole nearly cancel when radius ≪ z.
    fn cumulative(&self, radius: f32) -> f32 {
        let (r2, sigma) = ((radius as f64).powi(2), self.sigma_tr as f64);
        let part = |z: f32| {
            let z = z as f64;
            let d = (r2 + z * z).sqrt();
            (-sigma * z).exp() - z * (-sigma * d).exp() / d
        };
        (0.5 * self.alpha as f64 * (part(self.zr) + part(self.zv))).max(0.0) as f32
    }
}

/// The dipole of one material point, per colour channel, with the smoothing radius `h`.
#[derive(Clone, Copy, Debug)]
pub struct Dipole {
    channels: [Channel; 3],
    /// Boundary term A.
    a: f32,
    h2: f32,
}

/// Smallest mean free path and smoothing radius, so every quantity stays finite in f32.
const MIN_LENGTH: f32 = 1e-12;

impl Dipole {
    /// `reflectance` is the total diffuse reflectance to reproduce (the base colour), `mfp` the
    /// reduced mean free path per channel (scene units), `eta` the relative IOR, `h` the
    /// smoothing radius. Non-finite or non-positive lengths are clamped to tiny ones.
    pub fn new(reflectance: Vec3, mfp: Vec3, eta: f32, h: f32) -> Dipole {
        let clean = |v: f32| {
            if v.is_finite() {
                v.max(MIN_LENGTH)
            } else {
                MIN_LENGTH
            }
        };
        let h = clean(h);
        let a = boundary_term(eta);
        let channels = std::array::from_fn(|i| Channel::new(reflectance[i], clean(mfp[i]), a, h));
        Dipole {
            channels,
            a,
            h2: h * h,
        }
    }

    fn map(&self, f: impl Fn(&Channel) -> f32) -> Vec3 {
        Vec3::new(
            f(&self.channels[0]),
            f(&self.channels[1]),
            f(&self.channels[2]),
        )
    }

    /// The reduced albedo α′ per channel.
    pub fn reduced_albedo(&self) -> Vec3 {
        self.map(|c| c.alpha)
    }

    /// R_d(r) per channel for squared distance `r2` (per unit area).
    pub fn rd(&self, r2: f32) -> Vec3 {
        self.map(|c| c.rd(r2))
    }

    /// ∫ R_d over the disc of radius `radius` (closed form).
    pub fn cumulative(&self, radius: f32) -> Vec3 {
        self.map(|c| c.cumulative(radius))
    }

    /// Total diffuse reflectance P(∞).
    pub fn total(&self) -> Vec3 {
        self.map(|c| total_reflectance(c.alpha, self.a))
    }

    /// The kernel summed over a cluster of samples seen from offset `v` (x − the cluster's
    /// weighted centre, beyond the smoothing radius), per unit of the cluster's flux, to second
    /// order in the samples' spread about the centre: R_d(r) + ½ tr(H Σ), with H the Hessian of
    /// R_d(‖v‖), R_d″ along v̂ and R_d′/r across it, and Σ the cluster's weighted covariance
    /// (`spread`: xx, yy, zz, xy, xz, yz). The first-order term vanishes about the weighted
    /// centre; the second corrects the convexity of R_d, which makes the centre alone read low.
    pub fn cluster_kernel(&self, v: Vec3, spread: &[f32; 6]) -> Vec3 {
        let r2 = v.length_squared();
        let [xx, yy, zz, xy, xz, yz] = *spread;
        let trace = xx + yy + zz;
        let along = if r2 > 0.0 {
            (v.x * v.x * xx
                + v.y * v.y * yy
                + v.z * v.z * zz
                + 2.0 * (v.x * v.y * xy + v.x * v.z * xz + v.y * v.z * yz))
                / r2
        } else {
            0.0
        };
        self.map(|c| {
            let [k, k1_over_r, k2] = c.rd_derivatives(r2);
            (k + 0.5 * (k2 * along + k1_over_r * (trace - along))).max(0.0)
        })
    }

    /// The sample kernel: R_d(r) beyond the smoothing radius, its disc mean inside.
    pub fn kernel(&self, r2: f32) -> Vec3 {
        if r2 < self.h2 {
            self.map(|c| c.inner)
        } else {
            self.rd(r2)
        }
    }
}

/// One irradiance sample: a point on the translucent surface and the flux that entered there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    pub position: Vec3,
    pub flux: Vec3,
}

#[derive(Clone, Copy, Debug)]
struct Node {
    min: Vec3,
    max: Vec3,
    /// Flux-weighted centre (by the sum of the channels; the box centre when the flux is zero).
    centre: Vec3,
    /// Weighted covariance of the samples' positions about `centre` (xx, yy, zz, xy, xz, yz).
    spread: [f32; 6],
    flux: Vec3,
    /// Area the node's samples represent, at least its box's extent.
    area: f32,
    /// Children are `first..first + count` in `nodes` for inner nodes, samples for leaves.
    first: u32,
    count: u32,
    leaf: bool,
}

/// The octree of Jensen & Buhler over the samples of one translucent material.
#[derive(Clone, Debug)]
pub struct SampleTree {
    nodes: Vec<Node>,
    samples: Vec<Sample>,
    smoothing: f32,
}

impl SampleTree {
    /// Build over `samples` that together represent `area` (the translucent surface's area).
    /// The smoothing radius h covers about `smoothing_samples` samples: πh² = that many areas
    /// per sample.
    pub fn build(mut samples: Vec<Sample>, area: f32, smoothing_samples: f32) -> SampleTree {
        samples.retain(|s| s.position.is_finite() && s.flux.is_finite());
        let n = samples.len().max(1) as f32;
        let per_sample = if area.is_finite() && area > 0.0 {
            area / n
        } else {
            0.0
        };
        let smoothing = (smoothing_samples.max(0.0) * per_sample / PI).sqrt();
        let mut tree = SampleTree {
            nodes: Vec::with_capacity(samples.len() / 2 + 1),
            samples: Vec::new(),
            smoothing,
        };
        if !samples.is_empty() {
            tree.nodes.push(Self::summary(&samples, 0, per_sample));
            tree.split(0, &mut samples, 0, 0, per_sample);
        }
        tree.samples = samples;
        tree
    }

    fn summary(samples: &[Sample], first: usize, per_sample: f32) -> Node {
        let (mut min, mut max) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
        let (mut flux, mut weighted, mut weight) = (Vec3::ZERO, Vec3::ZERO, 0.0f32);
        for s in samples {
            min = min.min(s.position);
            max = max.max(s.position);
            flux += s.flux;
            let w = s.flux.x + s.flux.y + s.flux.z;
            weighted += s.position * w;
            weight += w;
        }
        let centre = if weight > 0.0 {
            (weighted / weight).clamp(min, max)
        } else {
            0.5 * (min + max)
        };
        let mut spread = [0.0f32; 6];
        if weight > 0.0 {
            for s in samples {
                let w = (s.flux.x + s.flux.y + s.flux.z) / weight;
                let p = s.position - centre;
                let terms = [
                    p.x * p.x,
                    p.y * p.y,
                    p.z * p.z,
                    p.x * p.y,
                    p.x * p.z,
                    p.y * p.z,
                ];
                for (acc, t) in spread.iter_mut().zip(terms) {
                    *acc += w * t;
                }
            }
        }
        Node {
            min,
            max,
            centre,
            spread,
            flux,
            // Samples are denser where more light arrived (and where guided photons were
            // drawn), so the count alone can call a wide, sparse node small: the box's own
            // extent (half its squared diagonal: a square's area) bounds it from below.
            area: (per_sample * samples.len() as f32).max(0.5 * (max - min).length_squared()),
            first: first as u32,
            count: samples.len() as u32,
            leaf: true,
        }
    }

    /// Split node `index` (its samples are `samples`, starting at `offset` in the final order)
    /// into octants, recursively.
    fn split(
        &mut self,
        index: usize,
        samples: &mut [Sample],
        offset: usize,
        depth: u32,
        per_sample: f32,
    ) {
        if samples.len() <= LEAF_SIZE || depth >= MAX_DEPTH {
            return;
        }
        let node = self.nodes[index];
        let mid = 0.5 * (node.min + node.max);
        let octant = |p: Vec3| {
            (p.x > mid.x) as usize | ((p.y > mid.y) as usize) << 1 | ((p.z > mid.z) as usize) << 2
        };
        samples.sort_by_key(|s| octant(s.position));
        let mut ranges = Vec::with_capacity(8);
        let mut start = 0;
        while start < samples.len() {
            let o = octant(samples[start].position);
            let end = start + samples[start..].partition_point(|s| octant(s.position) == o);
            ranges.push(start..end);
            start = end;
        }
        if ranges.len() == 1 {
            // The bounds are attained on every axis, so one octant holds everything only when
            // all samples coincide: keep them as one leaf.
            return;
        }
        let first = self.nodes.len();
        for r in &ranges {
            self.nodes.push(Self::summary(
                &samples[r.clone()],
                offset + r.start,
                per_sample,
            ));
        }
        self.nodes[index].first = first as u32;
        self.nodes[index].count = ranges.len() as u32;
        self.nodes[index].leaf = false;
        for (i, r) in ranges.into_iter().enumerate() {
            let start = r.start;
            self.split(
                first + i,
                &mut samples[r],
                offset + start,
                depth + 1,
                per_sample,
            );
        }
    }

    /// The smoothing radius h (scene units).
    pub fn smoothing(&self) -> f32 {
        self.smoothing
    }

    pub fn len(&self) -> usize {
        self.samples.len()
    }

    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// The samples' bounding box (min, max); `None` without samples.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        self.nodes.first().map(|n| (n.min, n.max))
    }

    /// Total flux of all samples.
    pub fn total_flux(&self) -> Vec3 {
        self.nodes.first().map_or(Vec3::ZERO, |n| n.flux)
    }

    /// Radiant exitance M(x) = Σ K(‖x − x_p‖) ΔΦ_p by the hierarchical evaluation: nodes that
    /// subtend a solid angle below `accuracy` (and are further than h) count as one sample.
    /// Returns the exitance and the number of kernel evaluations.
    pub fn exitance(&self, x: Vec3, dipole: &Dipole, accuracy: f32) -> (Vec3, u32) {
        let mut sum = Vec3::ZERO;
        let mut evaluations = 0;
        if self.nodes.is_empty() {
            return (sum, 0);
        }
        let h2 = self.smoothing * self.smoothing;
        let mut stack = Vec::with_capacity(64);
        stack.push(0usize);
        while let Some(i) = stack.pop() {
            let node = &self.nodes[i];
            let d2 = (x - node.centre).length_squared();
            let box_d2 = (node.min - x)
                .max(x - node.max)
                .max(Vec3::ZERO)
                .length_squared();
            if box_d2 > h2 && node.area < accuracy * d2 {
                sum += dipole.cluster_kernel(x - node.centre, &node.spread) * node.flux;
                evaluations += 1;
            } else if node.leaf {
                let range = node.first as usize..(node.first + node.count) as usize;
                for s in &self.samples[range] {
                    sum += dipole.kernel((x - s.position).length_squared()) * s.flux;
                }
                evaluations += node.count;
            } else {
                stack.extend(node.first as usize..(node.first + node.count) as usize);
            }
        }
        (sum, evaluations)
    }

    /// M(x) summed over every sample (the reference for the hierarchical evaluation).
    /// Summed in f64: hundreds of thousands of small terms.
    pub fn exitance_brute_force(&self, x: Vec3, dipole: &Dipole) -> Vec3 {
        let sum = self.samples.iter().fold(glam::DVec3::ZERO, |sum, s| {
            sum + (dipole.kernel((x - s.position).length_squared()) * s.flux).as_dvec3()
        });
        sum.as_vec3()
    }
}

/// Exitance at fixed points of the surface, each computed once, on first use. The hierarchical
/// sum costs hundreds of kernel evaluations, and a render asks for M at many points within one
/// smoothing radius (every camera sample of every pixel): the caller interpolates M between
/// points it names by a key (`crate::integrator::photon::subsurface` uses a lattice over each
/// triangle). A point's value depends only on its key, so the image is the same whichever
/// thread computes it first. Past `max_points` stored points, new ones are computed each time
/// they are asked for and not kept (the same values, bounded memory).
pub struct ExitanceCache {
    max_per_shard: usize,
    shards: Vec<RwLock<HashMap<[u32; 4], Vec3>>>,
}

impl ExitanceCache {
    pub fn new(max_points: usize) -> ExitanceCache {
        ExitanceCache {
            max_per_shard: max_points / CACHE_SHARDS,
            shards: (0..CACHE_SHARDS)
                .map(|_| RwLock::new(HashMap::new()))
                .collect(),
        }
    }

    /// Points stored so far.
    pub fn len(&self) -> usize {
        self.shards
            .iter()
            .map(|s| s.read().map_or(0, |m| m.len()))
            .sum()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The value stored under `key`, else `exitance()`, stored.
    pub fn get_or_compute(&self, key: [u32; 4], exitance: impl FnOnce() -> Vec3) -> Vec3 {
        let hash = key
            .iter()
            .fold(0x811c_9dc5u32, |h, &k| (h ^ k).wrapping_mul(0x0100_0193));
        let shard = &self.shards[(hash >> 26) as usize % CACHE_SHARDS];
        if let Some(v) = shard.read().ok().and_then(|m| m.get(&key).copied()) {
            return v;
        }
        let v = exitance();
        if let Ok(mut m) = shard.write() {
            if m.len() < self.max_per_shard {
                m.insert(key, v);
            }
        }
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernel_is_finite_and_continuous_enough() {
        let d = Dipole::new(
            Vec3::new(0.8, 0.5, 0.1),
            Vec3::new(0.1, 0.01, 1e-6),
            1.3,
            0.02,
        );
        for r in [0.0, 0.019, 0.021, 1.0, 100.0] {
            assert!(d.kernel(r * r).is_finite(), "r = {r}");
        }
        // P(h) + ∫_h^∞ R_d = total, so the disc mean times the disc area is P(h).
        let p = d.cumulative(0.02);
        let inner = d.kernel(0.0) * (PI * 0.02 * 0.02);
        assert!((p - inner).abs().max_element() < 1e-5, "{p} vs {inner}");
    }

    #[test]
    fn cluster_kernel_corrects_the_centre_to_second_order() {
        // 400 equal samples on a 0.1 m square grid in the XY plane around the origin, seen
        // from 0.3 m away along X (and off the plane): their mean kernel against the value at
        // the centre alone and the second-order cluster value.
        let d = Dipole::new(
            Vec3::new(0.9, 0.6, 0.3),
            Vec3::new(0.05, 0.02, 0.01),
            1.4,
            0.01,
        );
        let points: Vec<Vec3> = (0..400)
            .map(|i| Vec3::new((i % 20) as f32 - 9.5, (i / 20) as f32 - 9.5, 0.0) * 0.005)
            .collect();
        let mut spread = [0.0f32; 6];
        for p in &points {
            let terms = [p.x * p.x, p.y * p.y, 0.0, p.x * p.y, 0.0, 0.0];
            for (acc, t) in spread.iter_mut().zip(terms) {
                *acc += t / points.len() as f32;
            }
        }
        for x in [Vec3::new(0.3, 0.0, 0.0), Vec3::new(0.2, 0.1, 0.15)] {
            let exact = points
                .iter()
                .map(|p| d.kernel((x - *p).length_squared()))
                .sum::<Vec3>()
                / points.len() as f32;
            let centre = d.kernel(x.length_squared());
            let cluster = d.cluster_kernel(x, &spread);
            // Blue's kernel falls by e over about its 0.01 m mean free path, a tenth of the
            // cluster: there the expansion only halves the error; elsewhere it removes 90 %.
            for (c, gain) in [(0, 0.1), (1, 0.1), (2, 0.5)] {
                let (e, k, q) = (exact[c], centre[c], cluster[c]);
                assert!(e > k, "convex: the centre alone reads low ({k} vs {e})");
                assert!(
                    (q - e).abs() < gain * (k - e).abs(),
                    "x {x}, channel {c}: cluster {q}, centre {k}, exact {e}"
                );
            }
        }
    }

    #[test]
    fn boundary_term_is_one_without_refraction() {
        assert!((boundary_term(1.0) - 1.0).abs() < 0.01);
        assert!(boundary_term(1.4) > 2.0);
    }
}
