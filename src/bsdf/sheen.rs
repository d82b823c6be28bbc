//! The microfiber sheen of Blender 4.x (Cycles' Sheen BSDF and the Principled BSDF's sheen
//! layer): Zeltner, Burley & Chiang 2022, "Practical Multiple-Scattering Sheen Using Linearly
//! Transformed Cosines". The reference is a unit-thickness volumetric layer of fibres standing
//! along the normal (an SGGX microflake medium, Heitz et al. 2015, with projected-area matrix
//! S = diag(1, 1, α⁴), α the sheen roughness, unit density, white single-scattering albedo,
//! specular microflakes, at most 16 scattering events, nothing below it). Its reflection seen
//! from cosine μ is approximated by a linearly transformed cosine (Heitz et al. 2016) scaled by
//! the layer's directional albedo R(μ, α):
//!
//!   f·cos θi = R · D(wi),  D(w) = z · a² / (π ((a x + b z)² + (a y)² + z²)²),
//!
//! in the frame whose x axis is the viewing direction's projection on the surface: the
//! inverse transform M⁻¹ = [[a, 0, b], [0, a, 0], [0, 0, 1]] maps the lobe back onto a clamped
//! cosine. D integrates to 1 and is sampled exactly (a cosine sample mapped by M), so the lobe's
//! albedo is R and its density is D.
//!
//! `(a, b, R)` are tabulated on 32 × 32 points (μ = i/31, α = j/31, each at least 0.01, read
//! bilinearly as Cycles reads its table). The table is ours: `bake` below simulates the layer
//! (random walks for R, next-event estimation of the reflected distribution on a 32 × 32 grid
//! of directions) and fits (a, b) by minimising the summed cubed error over that grid with
//! Nelder–Mead, warm-started from the rougher neighbour, as the paper describes. The result is
//! baked into `sheen_ltc.bin` (little-endian f32: a, b and R tables, each indexed
//! [α index × 32 + μ index]), written by
//! `PHOTON_BAKE_SHEEN=1 cargo test --release --lib sheen::tests::bake` (about ten minutes).

use crate::math::Vec3;
use std::f32::consts::{FRAC_1_PI, PI};
use std::sync::LazyLock;

/// Table points along μ and along α.
pub const SIZE: usize = 32;

const BAKED: &[u8] = include_bytes!("sheen_ltc.bin");

struct Table {
    a: Vec<f32>,
    b: Vec<f32>,
    r: Vec<f32>,
}

fn table() -> &'static Table {
    static TABLE: LazyLock<Table> = LazyLock::new(|| {
        let n = SIZE * SIZE;
        assert_eq!(
            BAKED.len(),
            4 * 3 * n,
            "sheen_ltc.bin does not match the table size"
        );
        let v: Vec<f32> = BAKED
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        Table {
            a: v[..n].to_vec(),
            b: v[n..2 * n].to_vec(),
            r: v[2 * n..].to_vec(),
        }
    });
    &TABLE
}

/// Bilinear lookup of a 32 × 32 table at (μ, α) ∈ [0, 1]².
fn lookup(t: &[f32], mu: f32, alpha: f32) -> f32 {
    let x = mu.clamp(0.0, 1.0) * (SIZE - 1) as f32;
    let y = alpha.clamp(0.0, 1.0) * (SIZE - 1) as f32;
    let (x0, y0) = ((x as usize).min(SIZE - 2), (y as usize).min(SIZE - 2));
    let (fx, fy) = (x - x0 as f32, y - y0 as f32);
    let at = |i: usize, j: usize| t[j * SIZE + i];
    let lo = at(x0, y0) + (at(x0 + 1, y0) - at(x0, y0)) * fx;
    let hi = at(x0, y0 + 1) + (at(x0 + 1, y0 + 1) - at(x0, y0 + 1)) * fx;
    lo + (hi - lo) * fy
}

/// The sheen lobe seen from cosine `mu` at roughness `roughness` (clamped to [0.001, 1], as
/// Cycles clamps it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SheenLobe {
    pub a: f32,
    pub b: f32,
    /// Directional albedo R(μ, α).
    pub albedo: f32,
}

impl SheenLobe {
    pub fn new(mu: f32, roughness: f32) -> SheenLobe {
        let t = table();
        let alpha = roughness.clamp(1e-3, 1.0);
        let mu = mu.clamp(0.0, 1.0);
        SheenLobe {
            a: lookup(&t.a, mu, alpha).max(1e-3),
            b: lookup(&t.b, mu, alpha),
            albedo: lookup(&t.r, mu, alpha).max(0.0),
        }
    }

    /// D(w) for `w` in the lobe's frame (x towards the viewer's azimuth): the cosine-weighted
    /// distribution, both f·cos θ / R and the sampling density.
    pub fn density(&self, w: Vec3) -> f32 {
        if !(w.z > 0.0) {
            return 0.0;
        }
        let (a, b) = (self.a, self.b);
        let u = a * w.x + b * w.z;
        let len2 = u * u + a * a * w.y * w.y + w.z * w.z;
        let v = a / len2;
        FRAC_1_PI * w.z * v * v
    }

    /// A direction distributed as `density` from two uniform numbers.
    pub fn sample(&self, u: [f32; 2]) -> Vec3 {
        let r = u[0].sqrt();
        let phi = 2.0 * PI * u[1];
        let (x, y) = (r * phi.cos(), r * phi.sin());
        let z = (1.0 - r * r).max(0.0).sqrt();
        Vec3::new((x - z * self.b) / self.a, y / self.a, z).normalize_or(Vec3::Z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫ D = 1 over the hemisphere for a few table entries (midpoint rule in (cos θ, φ)).
    #[test]
    fn lobes_are_normalised() {
        for &(mu, r) in &[(0.9f32, 0.5f32), (0.3, 0.2), (0.1, 0.9), (0.6, 0.05)] {
            let lobe = SheenLobe::new(mu, r);
            let integral = crate::bsdf::microfacet::hemisphere_integral(600, |w| lobe.density(w));
            assert!((integral - 1.0).abs() < 2e-3, "mu {mu} r {r}: {integral}");
        }
    }

    /// The baked albedo agrees with a fresh simulation of the layer at a few points, and the
    /// table is finite (re-bake with `PHOTON_BAKE_SHEEN=1`: see the module header).
    #[test]
    fn bake() {
        if std::env::var_os("PHOTON_BAKE_SHEEN").is_some() {
            let bytes = bake::bake();
            let path = concat!(env!("CARGO_MANIFEST_DIR"), "/src/bsdf/sheen_ltc.bin");
            std::fs::write(path, bytes).unwrap();
            return;
        }
        let t = table();
        assert!(t.a.iter().chain(&t.b).chain(&t.r).all(|v| v.is_finite()));
        assert!(t.a.iter().all(|&a| a > 0.0));
        for &(i, j) in &[(31usize, 15usize), (8, 24), (20, 6)] {
            let (mu, alpha) = (bake::grid(i), bake::grid(j));
            let fresh = bake::albedo(mu, alpha, 200_000, 7);
            let baked = t.r[j * SIZE + i] as f64;
            assert!(
                (fresh - baked).abs() < 0.005,
                "mu {mu} alpha {alpha}: {fresh} vs {baked}"
            );
        }
    }

    /// The fibre medium's visible-normal sampling reflects into the phase function it
    /// evaluates: a sampled direction's mean cosine against the phase function's integral.
    #[test]
    fn fibre_phase_sampling_matches_its_density() {
        use bake::Fibres;
        for &alpha in &[0.3f64, 0.7, 1.0] {
            let f = Fibres::new(alpha);
            let wi = [0.6f64, 0.0, 0.8];
            let mut rng = crate::rng::Rng::new(3);
            let n = 400_000;
            let mut sampled = [0.0f64; 3];
            for _ in 0..n {
                let wo = f.sample_phase(wi, bake::uniform(&mut rng), bake::uniform(&mut rng));
                for k in 0..3 {
                    sampled[k] += wo[k] * wo[k] / n as f64;
                }
            }
            // Quadrature of p(wi, wo) wo_k² over the sphere.
            let m = 800;
            let mut integral = [0.0f64; 3];
            let mut total = 0.0;
            for i in 0..m {
                let z = -1.0 + 2.0 * (i as f64 + 0.5) / m as f64;
                let s = (1.0 - z * z).sqrt();
                for j in 0..2 * m {
                    let phi = (j as f64 + 0.5) / (2 * m) as f64 * 2.0 * std::f64::consts::PI;
                    let wo = [s * phi.cos(), s * phi.sin(), z];
                    let p = f.phase(wi, wo) * (2.0 / m as f64) * (std::f64::consts::PI / m as f64);
                    total += p;
                    for k in 0..3 {
                        integral[k] += p * wo[k] * wo[k];
                    }
                }
            }
            assert!(
                (total - 1.0).abs() < 5e-3,
                "alpha {alpha}: phase integrates to {total}"
            );
            for k in 0..3 {
                assert!(
                    (sampled[k] - integral[k]).abs() < 5e-3,
                    "alpha {alpha} axis {k}: sampled {} vs {}",
                    sampled[k],
                    integral[k]
                );
            }
        }
    }

    /// The simulation and the fit, run by `bake` above.
    pub(super) mod bake {
        use super::super::SIZE;
        use crate::rng::Rng;
        use rayon::prelude::*;
        use std::f64::consts::PI;

        type V = [f64; 3];

        fn dot(a: V, b: V) -> f64 {
            a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
        }

        fn normalize(a: V) -> V {
            let l = dot(a, a).sqrt();
            [a[0] / l, a[1] / l, a[2] / l]
        }

        pub fn uniform(rng: &mut Rng) -> f64 {
            let hi = rng.next_u32() as u64;
            let lo = rng.next_u32() as u64;
            (((hi << 21) ^ lo) & ((1u64 << 53) - 1)) as f64 / (1u64 << 53) as f64
        }

        /// Table point `i` of either axis (at least 0.01, as the paper's grid).
        pub fn grid(i: usize) -> f64 {
            (i as f64 / (SIZE - 1) as f64).max(0.01)
        }

        /// Fibres along z: an SGGX medium with S = diag(1, 1, s), s = α⁴, i.e. the normals of
        /// an ellipsoid stretched along z by 1/α².
        pub struct Fibres {
            s: f64,
            /// sqrt(s) = α²: the ellipsoid's inverse stretch along z.
            k: f64,
        }

        impl Fibres {
            pub fn new(alpha: f64) -> Fibres {
                let k = alpha * alpha;
                Fibres { s: k * k, k }
            }

            /// Projected area along `w` (the extinction coefficient at unit density).
            pub fn area(&self, w: V) -> f64 {
                (w[0] * w[0] + w[1] * w[1] + self.s * w[2] * w[2]).sqrt()
            }

            fn ndf(&self, m: V) -> f64 {
                let q = m[0] * m[0] + m[1] * m[1] + m[2] * m[2] / self.s;
                1.0 / (PI * self.k * q * q)
            }

            /// Specular microflake phase function: light arriving from `wi` (pointing back
            /// along its path) scattered to `wo`.
            pub fn phase(&self, wi: V, wo: V) -> f64 {
                let h = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
                let l = dot(h, h);
                if !(l > 0.0) {
                    return 0.0;
                }
                self.ndf(normalize(h)) / (4.0 * self.area(wi))
            }

            /// A normal visible from `wi`: map the ellipsoid onto the unit sphere, pick a point
            /// of the sphere's visible half uniformly in projected area, map its normal back.
            fn visible_normal(&self, wi: V, u1: f64, u2: f64) -> V {
                let v = normalize([wi[0], wi[1], self.k * wi[2]]);
                let t1 = if v[2].abs() < 0.999 {
                    normalize([-v[1], v[0], 0.0])
                } else {
                    [1.0, 0.0, 0.0]
                };
                let t2 = [
                    v[1] * t1[2] - v[2] * t1[1],
                    v[2] * t1[0] - v[0] * t1[2],
                    v[0] * t1[1] - v[1] * t1[0],
                ];
                let r = u1.sqrt();
                let phi = 2.0 * PI * u2;
                let (p1, p2) = (r * phi.cos(), r * phi.sin());
                let h = (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
                let u = [
                    p1 * t1[0] + p2 * t2[0] + h * v[0],
                    p1 * t1[1] + p2 * t2[1] + h * v[1],
                    p1 * t1[2] + p2 * t2[2] + h * v[2],
                ];
                normalize([u[0], u[1], self.k * u[2]])
            }

            /// The direction light from `wi` leaves in after one scattering event.
            pub fn sample_phase(&self, wi: V, u1: f64, u2: f64) -> V {
                let m = self.visible_normal(wi, u1, u2);
                let c = 2.0 * dot(m, wi);
                normalize([c * m[0] - wi[0], c * m[1] - wi[1], c * m[2] - wi[2]])
            }
        }

        const MAX_EVENTS: usize = 16;

        /// One random walk into the layer from `wi` (unit thickness, unit density, white
        /// albedo, at most `MAX_EVENTS` scattering events), calling `event(depth, towards)` at
        /// each scattering point (`towards`: where the light came from); returns whether the
        /// walk's last direction points up (the reference counts such a walk as reflected).
        fn walk(f: &Fibres, wi: V, rng: &mut Rng, mut event: impl FnMut(f64, V)) -> bool {
            let mut dir = [-wi[0], -wi[1], -wi[2]];
            let mut depth = 0.0;
            for _ in 0..MAX_EVENTS {
                let t = -(1.0 - uniform(rng)).ln() / f.area(dir);
                depth -= t * dir[2];
                if !(0.0..=1.0).contains(&depth) {
                    break;
                }
                let back = [-dir[0], -dir[1], -dir[2]];
                event(depth, back);
                dir = f.sample_phase(back, uniform(rng), uniform(rng));
            }
            dir[2] >= 0.0
        }

        fn incident(mu: f64) -> V {
            [(1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu]
        }

        /// The layer's directional albedo seen from cosine `mu`, from `n` walks.
        pub fn albedo(mu: f64, alpha: f64, n: usize, seed: u64) -> f64 {
            let f = Fibres::new(alpha);
            let mut rng = Rng::new(seed);
            let up = (0..n)
                .filter(|_| walk(&f, incident(mu), &mut rng, |_, _| {}))
                .count();
            up as f64 / n as f64
        }

        /// Outgoing directions of the fit: θ and φ ∈ [0, π] at cell centres (the lobe is
        /// symmetric about the plane of incidence).
        const DIRS: usize = 32;

        fn directions() -> Vec<V> {
            let mut out = Vec::with_capacity(DIRS * DIRS);
            for i in 0..DIRS {
                let theta = (i as f64 + 0.5) / DIRS as f64 * 0.5 * PI;
                for j in 0..DIRS {
                    let phi = (j as f64 + 0.5) / DIRS as f64 * PI;
                    out.push([
                        theta.sin() * phi.cos(),
                        theta.sin() * phi.sin(),
                        theta.cos(),
                    ]);
                }
            }
            out
        }

        /// f·cos θo of the layer at `directions()` by next-event estimation from `n` walks.
        fn reflected(mu: f64, alpha: f64, n: usize, seed: u64) -> Vec<f64> {
            let f = Fibres::new(alpha);
            let dirs = directions();
            // Extinction per unit depth along each θ row.
            let ext: Vec<f64> = (0..DIRS)
                .map(|i| f.area(dirs[i * DIRS]) / dirs[i * DIRS][2])
                .collect();
            let mut sum = vec![0.0f64; dirs.len()];
            let mut rng = Rng::new(seed);
            let mut attenuation = [0.0f64; DIRS];
            for _ in 0..n {
                walk(&f, incident(mu), &mut rng, |depth, back| {
                    for (a, e) in attenuation.iter_mut().zip(&ext) {
                        *a = (-depth * e).exp();
                    }
                    let scale = 1.0 / (4.0 * f.area(back));
                    for (k, (s, w)) in sum.iter_mut().zip(&dirs).enumerate() {
                        let h = [back[0] + w[0], back[1] + w[1], back[2] + w[2]];
                        let l = dot(h, h);
                        if l > 0.0 {
                            *s += f.ndf(normalize(h)) * scale * attenuation[k / DIRS];
                        }
                    }
                });
            }
            sum.iter().map(|s| s / n as f64).collect()
        }

        /// The fitted lobe's f·cos θo at `directions()`.
        fn ltc_values(a: f64, b: f64, r: f64, dirs: &[V], out: &mut [f64]) {
            for (o, w) in out.iter_mut().zip(dirs) {
                let u = a * w[0] + b * w[2];
                let len2 = u * u + a * a * w[1] * w[1] + w[2] * w[2];
                *o = r * w[2] * a * a / (PI * len2 * len2);
            }
        }

        /// Nelder–Mead minimisation of `f` over two parameters from `x0`.
        fn minimise(f: impl Fn([f64; 2]) -> f64, x0: [f64; 2]) -> [f64; 2] {
            let mut s = [x0, [x0[0] + 0.05, x0[1]], [x0[0], x0[1] + 0.05]];
            let mut v = s.map(&f);
            for _ in 0..20_000 {
                let mut order = [0usize, 1, 2];
                order.sort_by(|&i, &j| v[i].total_cmp(&v[j]));
                s = order.map(|i| s[i]);
                v = order.map(|i| v[i]);
                let size = (s[1][0] - s[0][0]).abs().max((s[1][1] - s[0][1]).abs())
                    + (s[2][0] - s[0][0]).abs().max((s[2][1] - s[0][1]).abs());
                if size < 1e-7 {
                    break;
                }
                let c = [(s[0][0] + s[1][0]) / 2.0, (s[0][1] + s[1][1]) / 2.0];
                let at = |t: f64| [c[0] + t * (s[2][0] - c[0]), c[1] + t * (s[2][1] - c[1])];
                let xr = at(-1.0);
                let fr = f(xr);
                if fr < v[0] {
                    let xe = at(-2.0);
                    let fe = f(xe);
                    (s[2], v[2]) = if fe < fr { (xe, fe) } else { (xr, fr) };
                } else if fr < v[1] {
                    (s[2], v[2]) = (xr, fr);
                } else {
                    let xc = if fr < v[2] { at(-0.5) } else { at(0.5) };
                    let fc = f(xc);
                    if fc < v[2].min(fr) {
                        (s[2], v[2]) = (xc, fc);
                    } else {
                        for k in 1..3 {
                            s[k] = [(s[k][0] + s[0][0]) / 2.0, (s[k][1] + s[0][1]) / 2.0];
                            v[k] = f(s[k]);
                        }
                    }
                }
            }
            let best = (0..3).min_by(|&i, &j| v[i].total_cmp(&v[j])).unwrap();
            s[best]
        }

        /// Walks per table point for the albedo and for the reflected distribution.
        const ALBEDO_WALKS: usize = 1_000_000;
        const SHAPE_WALKS: usize = 20_000;

        /// The whole table as `sheen_ltc.bin` stores it.
        pub fn bake() -> Vec<u8> {
            let n = SIZE * SIZE;
            let dirs = directions();
            // Per μ row: simulate every α, then fit from the roughest down.
            let rows: Vec<Vec<(f64, f64, f64)>> = (0..SIZE)
                .into_par_iter()
                .map(|i| {
                    let mu = grid(i);
                    let sims: Vec<(f64, Vec<f64>)> = (0..SIZE)
                        .map(|j| {
                            let alpha = grid(j);
                            let seed = (i * SIZE + j) as u64;
                            (
                                albedo(mu, alpha, ALBEDO_WALKS, seed),
                                reflected(mu, alpha, SHAPE_WALKS, seed + 1_000_000),
                            )
                        })
                        .collect();
                    let mut out = vec![(0.0, 0.0, 0.0); SIZE];
                    let mut x = [1.0, 0.0];
                    for j in (0..SIZE).rev() {
                        let (r, data) = &sims[j];
                        // Points where (almost) no light comes back keep the rougher fit.
                        if *r >= 3e-6 {
                            let err = |p: [f64; 2]| {
                                if !(p[0] > 1e-4) {
                                    return f64::MAX;
                                }
                                let mut buf = vec![0.0; dirs.len()];
                                ltc_values(p[0], p[1], *r, &dirs, &mut buf);
                                buf.iter()
                                    .zip(data)
                                    .map(|(a, b)| (a - b).abs().powi(3))
                                    .sum()
                            };
                            x = minimise(err, x);
                        }
                        out[j] = (x[0], x[1], *r);
                    }
                    eprintln!("sheen bake: row mu={mu:.3} done");
                    out
                })
                .collect();
            let mut a = vec![0.0f32; n];
            let mut b = vec![0.0f32; n];
            let mut r = vec![0.0f32; n];
            for (i, row) in rows.iter().enumerate() {
                for (j, &(pa, pb, pr)) in row.iter().enumerate() {
                    a[j * SIZE + i] = pa as f32;
                    b[j * SIZE + i] = pb as f32;
                    r[j * SIZE + i] = pr as f32;
                }
            }
            [a, b, r]
                .iter()
                .flat_map(|t| t.iter().flat_map(|v| v.to_le_bytes()))
                .collect()
        }
    }
}
