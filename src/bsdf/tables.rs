//! Albedo tables for energy compensation and layering, integrated numerically with deterministic
//! stratified visible-normal samples and baked into the binary (`albedo_tables.bin`: the
//! integration takes ~80 ms, most of a small preview render; a test rebuilds the tables and
//! checks the baked copy):
//!
//! - `E(μ, r)`: directional albedo of a white single-scattering GGX reflector, and its cosine-
//!   weighted average `E_avg(r)`: what multiscatter compensation needs (Kulla & Conty 2017,
//!   "Revisiting Physically Based Shading at Imageworks", §"Energy compensation"; the same
//!   quantities as Cycles' `ggx_E` / `ggx_Eavg` tables);
//! - `s̄(μ, r, z)`: the lobe-averaged Fresnel blend factor of a dielectric GGX reflector, so the
//!   specular layer's albedo is mix(F0·tint, 1, s̄) · E (plus the multiscatter term), which the
//!   Principled layering subtracts from the diffuse base ("albedo scaling");
//! - `s_avg(z)`: the cosine-weighted hemispherical average of the blend factor (Fss for the
//!   compensation's multi-bounce Fresnel);
//! - `E_glass(μ, r, z)` seen from outside (relative IOR η > 1) and from inside (1/η): the
//!   directional albedo, reflection plus refraction, of a white single-scattering GGX glass
//!   (Walter et al. 2007, flux conserved across the interface). Multiscatter GGX glass divides
//!   its lobe by it, as Cycles' `ggx_glass_E` / `ggx_glass_inv_E` tables do.
//!
//! `r` is perceptual roughness (α = r²), `z = F0^(1/4) = sqrt((η − 1)/(η + 1))`; the μ axes are
//! uniform in sqrt(μ).

use super::fresnel::{fresnel_blend_factor, fresnel_dielectric};
use super::microfacet::{ggx_g1, ggx_g2, sample_ggx_vndf, MIN_ALPHA};
use crate::math::{reflect, refract, Vec3};
use std::sync::LazyLock;

const E_ROUGH: usize = 32;
const E_MU: usize = 32;
const S_ROUGH: usize = 16;
const S_MU: usize = 32;
const S_Z: usize = 16;
const AVG_Z: usize = 64;
const GLASS_ROUGH: usize = 16;
const GLASS_MU: usize = 16;
const GLASS_Z: usize = 16;
const GLASS_SIDE: usize = GLASS_ROUGH * GLASS_MU * GLASS_Z;

pub struct AlbedoTables {
    e: Vec<f32>,
    e_avg: Vec<f32>,
    s_bar: Vec<f32>,
    s_avg: Vec<f32>,
    /// `E_glass` from outside, then from inside.
    glass_e: Vec<f32>,
}

/// The baked tables: `AlbedoTables::build`'s output as little-endian f32 (e, e_avg, s_bar,
/// s_avg in order), written by `PHOTON_BAKE_TABLES=1 cargo test --release --lib tables`.
const BAKED: &[u8] = include_bytes!("albedo_tables.bin");

/// The tables, read from the baked copy on first use.
pub fn albedo_tables() -> &'static AlbedoTables {
    static TABLES: LazyLock<AlbedoTables> = LazyLock::new(|| AlbedoTables::from_bytes(BAKED));
    &TABLES
}

fn grid(i: usize, n: usize) -> f32 {
    i as f32 / (n - 1) as f32
}

/// The μ axes are uniform in t = sqrt(μ): Fresnel and masking change fastest near grazing.
fn mu_of(t: f32) -> f32 {
    t * t
}

fn alpha_of(rough: f32) -> f32 {
    (rough * rough).max(MIN_ALPHA)
}

fn eta_of_z(z: f32) -> f32 {
    let z2 = (z * z).min(0.998);
    (1.0 + z2) / (1.0 - z2)
}

/// View direction with cosine `mu` (kept away from exact grazing).
fn view(mu: f32) -> Vec3 {
    let mu = mu.clamp(1e-3, 1.0);
    Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu)
}

/// Stratified reflected samples of a white GGX reflector seen from `wo`: calls `f(h, weight)`
/// where the mean of `weight` is the directional albedo E.
fn for_each_reflection(alpha: f32, wo: Vec3, n: usize, mut f: impl FnMut(Vec3, f32)) {
    let g1 = ggx_g1(alpha, wo);
    for i in 0..n {
        for j in 0..n {
            let u = [(i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32];
            let h = sample_ggx_vndf(alpha, wo, u);
            let wi = reflect(wo, h);
            let weight = if wi.z > 0.0 && g1 > 0.0 {
                ggx_g2(alpha, wo, wi) / g1
            } else {
                0.0
            };
            f(h, weight);
        }
    }
}

impl AlbedoTables {
    /// Table lengths in `BAKED` order.
    const LENGTHS: [usize; 5] = [
        E_ROUGH * E_MU,
        E_ROUGH,
        S_ROUGH * S_MU * S_Z,
        AVG_Z,
        2 * GLASS_SIDE,
    ];

    fn from_bytes(bytes: &[u8]) -> Self {
        let total: usize = Self::LENGTHS.iter().sum();
        assert_eq!(
            bytes.len(),
            4 * total,
            "albedo_tables.bin does not match the table sizes"
        );
        let mut values = bytes
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]));
        let mut next = |n: usize| values.by_ref().take(n).collect::<Vec<f32>>();
        let [e, e_avg, s_bar, s_avg, glass_e] = Self::LENGTHS;
        AlbedoTables {
            e: next(e),
            e_avg: next(e_avg),
            s_bar: next(s_bar),
            s_avg: next(s_avg),
            glass_e: next(glass_e),
        }
    }

    /// The tables as `albedo_tables.bin` stores them.
    pub fn to_bytes(&self) -> Vec<u8> {
        [
            &self.e,
            &self.e_avg,
            &self.s_bar,
            &self.s_avg,
            &self.glass_e,
        ]
        .into_iter()
        .flat_map(|t| t.iter().flat_map(|v| v.to_le_bytes()))
        .collect()
    }

    /// Integrate the tables (what `albedo_tables.bin` holds).
    pub fn build() -> Self {
        let e_rows: Vec<Vec<f32>> = (0..E_ROUGH)
            .map(|ir| {
                let alpha = alpha_of(grid(ir, E_ROUGH));
                (0..E_MU)
                    .map(|im| {
                        let mut sum = 0.0f64;
                        let n = 32;
                        for_each_reflection(alpha, view(mu_of(grid(im, E_MU))), n, |_, w| {
                            sum += w as f64
                        });
                        (sum / (n * n) as f64) as f32
                    })
                    .collect()
            })
            .collect();
        let e_avg = e_rows
            .iter()
            .map(|row| {
                // E_avg = 2∫E(μ)μ dμ = 4∫E(t²)t³ dt (μ = t²), trapezoid rule on the row.
                let h = 1.0 / (E_MU - 1) as f32;
                let mut acc = 0.0;
                for im in 0..E_MU - 1 {
                    let (t0, t1) = (grid(im, E_MU), grid(im + 1, E_MU));
                    acc += 0.5 * h * (row[im] * t0.powi(3) + row[im + 1] * t1.powi(3));
                }
                (4.0 * acc).min(1.0)
            })
            .collect();
        let e = e_rows.concat();

        let etas: Vec<f32> = (0..S_Z).map(|iz| eta_of_z(grid(iz, S_Z))).collect();
        let s_rows: Vec<Vec<f32>> = (0..S_ROUGH)
            .map(|ir| {
                let alpha = alpha_of(grid(ir, S_ROUGH));
                let mut row = vec![0.0; S_MU * S_Z];
                for im in 0..S_MU {
                    let wo = view(mu_of(grid(im, S_MU)));
                    let mut weighted = [0.0f64; S_Z];
                    let mut total = 0.0f64;
                    for_each_reflection(alpha, wo, 16, |h, w| {
                        if w > 0.0 {
                            total += w as f64;
                            let cos_oh = wo.dot(h);
                            for (acc, &eta) in weighted.iter_mut().zip(&etas) {
                                *acc += (w * fresnel_blend_factor(cos_oh, eta)) as f64;
                            }
                        }
                    });
                    for iz in 0..S_Z {
                        row[im * S_Z + iz] = if total > 0.0 {
                            (weighted[iz] / total) as f32
                        } else {
                            fresnel_blend_factor(wo.z, etas[iz])
                        };
                    }
                }
                row
            })
            .collect();
        let s_bar = s_rows.concat();

        let s_avg = (0..AVG_Z)
            .map(|iz| {
                let eta = eta_of_z(grid(iz, AVG_Z));
                let n = 512;
                let sum: f32 = (0..n)
                    .map(|i| {
                        let mu = (i as f32 + 0.5) / n as f32;
                        fresnel_blend_factor(mu, eta) * mu
                    })
                    .sum();
                2.0 * sum / n as f32
            })
            .collect();

        let glass_e = [false, true]
            .into_iter()
            .flat_map(|inside| {
                (0..GLASS_ROUGH).flat_map(move |ir| {
                    (0..GLASS_MU).flat_map(move |im| {
                        (0..GLASS_Z).map(move |iz| {
                            let eta = eta_of_z(grid(iz, GLASS_Z));
                            let eta = if inside { 1.0 / eta } else { eta };
                            let mu = mu_of(grid(im, GLASS_MU));
                            glass_albedo(alpha_of(grid(ir, GLASS_ROUGH)), view(mu), eta, 32)
                        })
                    })
                })
            })
            .collect();

        AlbedoTables {
            e,
            e_avg,
            s_bar,
            s_avg,
            glass_e,
        }
    }

    /// Directional albedo of a white single-scattering GGX reflector.
    pub fn ggx_e(&self, mu: f32, rough: f32) -> f32 {
        lerp_2d(&self.e, E_ROUGH, E_MU, rough, mu.max(0.0).sqrt())
    }

    /// Cosine-weighted average of `ggx_e` over the hemisphere.
    pub fn ggx_e_avg(&self, rough: f32) -> f32 {
        lerp_1d(&self.e_avg, rough)
    }

    /// Lobe-averaged Fresnel blend factor of a dielectric GGX reflector of relative IOR `eta`.
    pub fn dielectric_s_bar(&self, mu: f32, rough: f32, eta: f32) -> f32 {
        let t = [rough, mu.max(0.0).sqrt(), z_of_eta(eta)];
        lerp_3d(&self.s_bar, [S_ROUGH, S_MU, S_Z], t)
    }

    /// Cosine-weighted hemispherical average of the Fresnel blend factor.
    pub fn dielectric_s_avg(&self, eta: f32) -> f32 {
        lerp_1d(&self.s_avg, z_of_eta(eta))
    }

    /// Directional albedo (reflection plus refraction) of a white single-scattering GGX glass
    /// of relative IOR `eta` (η > 1 seen from outside, < 1 from inside).
    pub fn glass_e(&self, mu: f32, rough: f32, eta: f32) -> f32 {
        let side = if eta < 1.0 {
            &self.glass_e[GLASS_SIDE..]
        } else {
            &self.glass_e[..GLASS_SIDE]
        };
        let (x, y, z) = (rough, mu.max(0.0).sqrt(), z_of_eta(eta));
        lerp_3d(side, [GLASS_ROUGH, GLASS_MU, GLASS_Z], [x, y, z])
    }
}

/// `E_glass` by stratified visible-normal samples (n × n): each microfacet reflects the
/// dielectric Fresnel F and refracts 1 − F, weighed G2/G1 (the glass lobe's sample weight);
/// what leaves on the wrong side is lost.
fn glass_albedo(alpha: f32, wo: Vec3, eta: f32, n: usize) -> f32 {
    let g1 = ggx_g1(alpha, wo);
    let mut sum = 0.0f64;
    for i in 0..n {
        for j in 0..n {
            let u = [(i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32];
            let h = sample_ggx_vndf(alpha, wo, u);
            let f = fresnel_dielectric(wo.dot(h), eta);
            let wr = reflect(wo, h);
            if wr.z > 0.0 {
                sum += (f * ggx_g2(alpha, wo, wr) / g1) as f64;
            }
            if let Some(wt) = refract(wo, h, eta).filter(|wt| wt.z < 0.0) {
                sum += ((1.0 - f) * ggx_g2(alpha, wo, wt) / g1) as f64;
            }
        }
    }
    (sum / (n * n) as f64) as f32
}

fn z_of_eta(eta: f32) -> f32 {
    let eta = if eta < 1.0 { 1.0 / eta } else { eta };
    ((eta - 1.0) / (eta + 1.0)).max(0.0).sqrt()
}

/// Continuous index of `t` ∈ [0, 1] on a grid of `n` points.
fn axis(t: f32, n: usize) -> f32 {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    t * (n - 1) as f32
}

fn lerp_1d(table: &[f32], t: f32) -> f32 {
    let x = axis(t, table.len());
    let i = (x.floor() as usize).min(table.len() - 1);
    let j = (i + 1).min(table.len() - 1);
    table[i] + (table[j] - table[i]) * (x - i as f32)
}

/// Trilinear lookup in a table of `n[0] × n[1] × n[2]` values (the last axis fastest) at
/// `t` ∈ [0, 1]³.
fn lerp_3d(table: &[f32], n: [usize; 3], t: [f32; 3]) -> f32 {
    let (x, y, z) = (axis(t[0], n[0]), axis(t[1], n[1]), axis(t[2], n[2]));
    let (x0, y0, z0) = (x.floor() as usize, y.floor() as usize, z.floor() as usize);
    let (x1, y1, z1) = (
        (x0 + 1).min(n[0] - 1),
        (y0 + 1).min(n[1] - 1),
        (z0 + 1).min(n[2] - 1),
    );
    let (fx, fy, fz) = (x - x0 as f32, y - y0 as f32, z - z0 as f32);
    let at = |i: usize, j: usize, k: usize| table[(i * n[1] + j) * n[2] + k];
    let plane = |k: usize| {
        let a = at(x0, y0, k) + (at(x1, y0, k) - at(x0, y0, k)) * fx;
        let b = at(x0, y1, k) + (at(x1, y1, k) - at(x0, y1, k)) * fx;
        a + (b - a) * fy
    };
    let (p0, p1) = (plane(z0), plane(z1));
    p0 + (p1 - p0) * fz
}

fn lerp_2d(table: &[f32], nx: usize, ny: usize, tx: f32, ty: f32) -> f32 {
    let (x, y) = (axis(tx, nx), axis(ty, ny));
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(nx - 1), (y0 + 1).min(ny - 1));
    let (fx, fy) = (x - x0 as f32, y - y0 as f32);
    let at = |i: usize, j: usize| table[i * ny + j];
    let a = at(x0, y0) + (at(x1, y0) - at(x0, y0)) * fx;
    let b = at(x0, y1) + (at(x1, y1) - at(x0, y1)) * fx;
    a + (b - a) * fy
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The baked tables are what `build` integrates today (a change to the BSDF's GGX or
    /// Fresnel code must re-bake them: run this test with `PHOTON_BAKE_TABLES=1`).
    #[test]
    fn baked_tables_match_a_fresh_build() {
        let fresh = AlbedoTables::build();
        if std::env::var_os("PHOTON_BAKE_TABLES").is_some() {
            let path = concat!(env!("CARGO_MANIFEST_DIR"), "/src/bsdf/albedo_tables.bin");
            std::fs::write(path, fresh.to_bytes()).unwrap();
            return;
        }
        let baked = AlbedoTables::from_bytes(BAKED);
        let fresh_bytes = fresh.to_bytes();
        let pairs = baked
            .to_bytes()
            .chunks_exact(4)
            .zip(fresh_bytes.chunks_exact(4))
            .map(|(a, b)| {
                let v = |c: &[u8]| f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
                (v(a), v(b))
            })
            .collect::<Vec<_>>();
        // Bit-exact on the machine that baked them; other libms may round sin/cos differently.
        let worst = pairs
            .iter()
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-5, "baked albedo tables differ from a fresh build by {worst}: re-bake with PHOTON_BAKE_TABLES=1");
    }

    #[test]
    fn tables_are_plausible() {
        let t = albedo_tables();
        // A smooth reflector loses nothing. At α = 1, D = 1/π, so E(μ = 1) ≤ (1/π)·2π/4 = 0.5;
        // reference values from a brute-force quadrature of D·G2/(4μo) over the hemisphere.
        assert!((t.ggx_e(0.7, 0.0) - 1.0).abs() < 1e-3);
        assert!((t.ggx_e(1.0, 1.0) - 0.3069).abs() < 3e-3);
        assert!((t.ggx_e(0.5, 1.0) - 0.4507).abs() < 3e-3);
        assert!((t.ggx_e(1.0, 0.5) - 0.9157).abs() < 3e-3);
        assert!(t.ggx_e_avg(1.0) > 0.3 && t.ggx_e_avg(1.0) < 0.6);
        // For a smooth surface s̄ is the blend factor at the view angle.
        let s = t.dielectric_s_bar(1.0, 0.0, 1.5);
        assert!(s.abs() < 1e-3, "{s}");
        assert!(t.dielectric_s_avg(1.5) > 0.0 && t.dielectric_s_avg(1.5) < 0.2);
        // Smooth glass loses nothing, from either side (total internal reflection included);
        // rough glass loses more the rougher it is.
        for &(mu, eta) in &[(1.0, 1.5), (0.3, 1.5), (1.0, 1.0 / 1.5), (0.3, 1.0 / 1.5)] {
            let smooth = t.glass_e(mu, 0.0, eta);
            assert!((smooth - 1.0).abs() < 2e-3, "μ = {mu}, η = {eta}: {smooth}");
        }
        let (e4, e8) = (t.glass_e(0.7, 0.4, 1.5), t.glass_e(0.7, 0.8, 1.5));
        assert!(e8 < e4 && e4 < 1.0 && e8 > 0.3, "{e4} {e8}");
    }
}
