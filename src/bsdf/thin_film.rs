//! Thin-film interference (iridescence) on a dielectric: the reflectance of a film of thickness
//! d (nanometres) and index η₂ lying on a substrate of index η₃, seen from a medium of index 1,
//! as Belcour & Barla 2017 ("A Practical Extension to Microfacet Theory for the Modeling of
//! Varying Iridescence") evaluate it and Blender 4.5's Cycles applies it to the Principled
//! BSDF's specular layer and glass: the Airy series of the waves reflected inside the film,
//! for s and p polarisation separately, summed in the Fourier domain over the CIE colour
//! matching functions (their Gaussian fit, orders m = 0…3), then taken from XYZ to linear
//! Rec. 709 with the white of D65 (the fit's illuminant is E; Cycles scales by the white point
//! instead of adapting). Films thinner than 30 nm fade towards no film (the film's index
//! towards 1), as Cycles does; below `MIN_THICKNESS` there is none.
//!
//! Energy: each polarisation's series is a reflectance of a lossless stack, so the result lies
//! in [0, 1] (clamped against the truncation and the fit), and a transmission lobe takes 1 − R.

use crate::math::Vec3;

/// Films at most this thick (nm) are absent (Cycles' threshold on the Thin Film Thickness).
pub const MIN_THICKNESS: f32 = 0.1;

/// Below this thickness (nm) the film's index fades towards the ambient medium's.
const FADE_THICKNESS: f32 = 30.0;

/// A film on a surface: thickness in nanometres and index of refraction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinFilm {
    pub thickness: f32,
    pub ior: f32,
}

impl ThinFilm {
    /// The film of a material's inputs; `None` when it is too thin to exist.
    pub fn new(thickness: f32, ior: f32) -> Option<ThinFilm> {
        (thickness.is_finite() && thickness > MIN_THICKNESS && ior.is_finite()).then(|| ThinFilm {
            thickness,
            ior: ior.max(1e-5),
        })
    }
}

/// `film` (a film's reflectance) mixed over `plain` (the film-free one) by `weight` in [0, 1]
/// (KHR_materials_iridescence's factor; Blender's film is whole).
pub fn weigh_film(plain: Vec3, film: Vec3, weight: f32) -> Vec3 {
    if weight >= 1.0 {
        film
    } else {
        plain + (film - plain) * weight.max(0.0)
    }
}

/// One interface's reflectance for s and p polarisation and whether each reflected wave turns
/// by π (its amplitude ratio is negative; dielectrics turn by 0 or π), light arriving at
/// cosine `cos_i` (> 0) on an interface of relative index `eta` = η_t / η_i. `None` on total
/// internal reflection; else also the transmitted cosine.
fn interface(cos_i: f32, eta: f32) -> Option<([f32; 2], [bool; 2], f32)> {
    let cos2_t = 1.0 - (1.0 - cos_i * cos_i) / (eta * eta);
    if !(cos2_t > 0.0) {
        return None;
    }
    let cos_t = cos2_t.sqrt();
    // Amplitude ratios (Born & Wolf §1.5.2).
    let r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    Some(([r_s * r_s, r_p * r_p], [r_s < 0.0, r_p < 0.0], cos_t))
}

/// Belcour & Barla's fit of the CIE 1931 colour matching functions' Fourier transforms: per
/// function (x̄ has a second lobe) an amplitude, a centre frequency and a variance.
const FIT: [(usize, f32, f32, f32); 4] = [
    (0, 5.4856e-13, 1.6810e6, 4.3278e9),
    (1, 4.4201e-13, 1.7953e6, 9.3046e9),
    (2, 5.2481e-13, 2.2084e6, 6.6121e9),
    (0, 1.64408e-8, 2.2399e6, 4.5282e9),
];

/// Their normalisation: a flat spectrum gives Y = 1.
const FIT_SCALE: f32 = 1.0 / 1.0685e-7;

/// The spectral sensitivity (XYZ) of the Airy terms of orders m = 1, 2, 3 at optical path
/// difference `opd` (nm) of one round trip, with no phase shift: the fit's transforms at
/// m × opd. A phase of 0 or π only flips the sign (`airy_series`), so the three orders share
/// one cosine and one exponential per lobe (cos 2x and cos 3x by Chebyshev's recurrence,
/// exp(−m²a) as powers of exp(−a)).
fn sensitivities(opd: f32) -> [Vec3; 3] {
    // Angular frequency of the path difference, with wavelength in metres.
    let w = std::f32::consts::TAU * opd * 1e-9;
    let mut out = [[0.0f32; 3]; 3];
    for (k, (xyz, amplitude, centre, variance)) in FIT.into_iter().enumerate() {
        // The first three lobes are Gaussians whose transform is scaled by sqrt(2π var).
        let scale = if k < 3 {
            amplitude * (std::f32::consts::TAU * variance).sqrt()
        } else {
            amplitude
        };
        let c1 = (centre * w).cos();
        let e1 = (-w * w * variance).exp();
        let c2 = 2.0 * c1 * c1 - 1.0;
        let c3 = c1 * (4.0 * c1 * c1 - 3.0);
        let e2 = (e1 * e1) * (e1 * e1);
        let e3 = e2 * e2 * e1;
        out[0][xyz] += scale * c1 * e1;
        out[1][xyz] += scale * c2 * e2;
        out[2][xyz] += scale * c3 * e3;
    }
    out.map(|v| Vec3::from(v) * FIT_SCALE)
}

/// The Airy series of one polarisation (Belcour & Barla eq. 10, orders 0…3), in XYZ: `r12`
/// the top interface's reflectance, `r23` the bottom's, `sens` the orders' sensitivities at
/// the film's path difference, `odd` whether the round trip's reflections add a phase of π
/// (then order m changes sign with m).
fn airy_series(r12: f32, r23: f32, sens: &[Vec3; 3], odd: bool) -> Vec3 {
    let t121 = 1.0 - r12;
    let r123 = r12 * r23;
    let amplitude = r123.sqrt();
    let inside = t121 * t121 * r23 / (1.0 - r123);
    let mut sum = Vec3::splat(r12 + inside);
    let mut c = inside - t121;
    let flip = if odd { -1.0 } else { 1.0 };
    for s in sens {
        c *= amplitude * flip;
        sum += 2.0 * c * *s;
    }
    sum
}

/// XYZ (with D65 as white) to linear Rec. 709.
fn xyz_to_rec709(c: Vec3) -> Vec3 {
    Vec3::new(
        3.240_454_2 * c.x - 1.537_138_5 * c.y - 0.498_531_4 * c.z,
        -0.969_266 * c.x + 1.876_010_8 * c.y + 0.041_556 * c.z,
        0.055_643_4 * c.x - 0.204_025_9 * c.y + 1.057_225_2 * c.z,
    )
}

/// The white of D65 in XYZ (Y = 1).
const D65: Vec3 = Vec3::new(0.950_47, 1.0, 1.088_83);

/// Reflectance (linear Rec. 709, in [0, 1]) of `film` on a substrate of index `substrate`,
/// light arriving from a medium of index 1 at cosine `cos_i`. 1 on total internal reflection
/// at either interface.
pub fn thin_film_reflectance(cos_i: f32, film: &ThinFilm, substrate: f32) -> Vec3 {
    let cos_i = cos_i.clamp(1e-6, 1.0);
    let mut film_ior = film.ior;
    if film.thickness < FADE_THICKNESS {
        let t = (film.thickness / FADE_THICKNESS).clamp(0.0, 1.0);
        film_ior = 1.0 + (film_ior - 1.0) * (t * t * (3.0 - 2.0 * t));
    }
    let Some((r12, flip12, cos_film)) = interface(cos_i, film_ior) else {
        return Vec3::ONE;
    };
    let Some((r23, flip23, _)) = interface(cos_film, substrate / film_ior) else {
        return Vec3::ONE;
    };
    let sens = sensitivities(2.0 * film_ior * film.thickness * cos_film);
    let mut xyz = Vec3::ZERO;
    for k in 0..2 {
        // A round trip's phase: π − φ₁₂ (the wave reflected back at the top from inside the
        // film) + φ₂₃, each φ 0 or π.
        let odd = !(flip12[k] ^ flip23[k]);
        xyz += 0.5 * airy_series(r12[k], r23[k], &sens, odd);
    }
    xyz_to_rec709(xyz * D65).clamp(Vec3::ZERO, Vec3::ONE)
}

/// Cycles' way of letting the Principled BSDF's F0 controls (Specular IOR Level, Specular
/// Tint) act on an iridescent reflectance `f` of a substrate whose real F0 is `f0_real`:
/// each channel is scaled towards `f0 / f0_real`, fully where it equals the real F0 and not
/// at all where it reaches 1.
pub fn scale_to_f0(f: Vec3, f0: Vec3, f0_real: f32) -> Vec3 {
    if !(f0_real > 1e-5) || f == Vec3::ONE {
        return f;
    }
    let channel = |f: f32, f0: f32| {
        let s = ((1.0 - f) / (1.0 - f0_real)).clamp(0.0, 1.0);
        (f * (1.0 + (f0 / f0_real - 1.0) * s)).clamp(0.0, 1.0)
    };
    Vec3::new(channel(f.x, f0.x), channel(f.y, f0.y), channel(f.z, f0.z))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::fresnel::fresnel_dielectric;

    /// A film of index 1 (or of the substrate's index) is no film: the plain Fresnel of the
    /// substrate, grey (the fit's white is the D65 white).
    #[test]
    fn an_invisible_film_gives_the_plain_fresnel() {
        for &cos in &[1.0f32, 0.8, 0.5, 0.2] {
            for film in [
                ThinFilm {
                    thickness: 500.0,
                    ior: 1.0,
                },
                ThinFilm {
                    thickness: 0.2,
                    ior: 1.33,
                },
            ] {
                let f = thin_film_reflectance(cos, &film, 1.5);
                let plain = fresnel_dielectric(cos, 1.5);
                assert!(
                    (f - Vec3::splat(plain)).abs().max_element() < 2e-3,
                    "{cos} {f} {plain}"
                );
            }
        }
        assert!(ThinFilm::new(0.0, 1.33).is_none());
        assert!(ThinFilm::new(MIN_THICKNESS, 1.33).is_none());
    }

    #[test]
    fn reflectance_stays_in_the_unit_interval() {
        for t in 0..60 {
            for &ior in &[1.1f32, 1.33, 1.8, 2.5] {
                for &sub in &[1.05f32, 1.5, 3.0, 0.7] {
                    for c in 0..20 {
                        let film = ThinFilm {
                            thickness: 1.0 + 25.0 * t as f32,
                            ior,
                        };
                        let f = thin_film_reflectance((c as f32 + 0.5) / 20.0, &film, sub);
                        assert!(f.is_finite() && f.min_element() >= 0.0 && f.max_element() <= 1.0);
                    }
                }
            }
        }
    }

    /// Reflectance of the film by summing the Airy series exactly at one wavelength (nm):
    /// the coherent sum of all the waves, |r₁₂ + t₁₂t₂₁r₂₃e^{iδ} / (1 − r₂₁r₂₃e^{iδ})|².
    fn airy_exact(cos_i: f32, film_ior: f64, substrate: f64, d: f64, lambda: f64) -> f64 {
        let cos_i = cos_i as f64;
        let sin2 = 1.0 - cos_i * cos_i;
        let cos2 = (1.0 - sin2 / (film_ior * film_ior)).sqrt();
        let cos3 = (1.0 - sin2 / (substrate * substrate)).sqrt();
        let delta = 4.0 * std::f64::consts::PI * film_ior * d * cos2 / lambda;
        let mut total = 0.0;
        for p in 0..2 {
            // Amplitude coefficients of (n_a, cos_a) → (n_b, cos_b), s or p.
            let r = |na: f64, ca: f64, nb: f64, cb: f64| {
                if p == 0 {
                    (na * ca - nb * cb) / (na * ca + nb * cb)
                } else {
                    (nb * ca - na * cb) / (nb * ca + na * cb)
                }
            };
            let r12 = r(1.0, cos_i, film_ior, cos2);
            let r23 = r(film_ior, cos2, substrate, cos3);
            // r21 = −r12 and t12·t21 = 1 − r12² for a lossless interface.
            let (c, s) = (delta.cos(), delta.sin());
            let num = (r12 + r23 * c, r23 * s);
            let den = (1.0 + r12 * r23 * c, r12 * r23 * s);
            let amp2 = (num.0 * num.0 + num.1 * num.1) / (den.0 * den.0 + den.1 * den.1);
            total += 0.5 * amp2;
        }
        total
    }

    /// At one wavelength far from the Gaussian fit's concerns, the series the module sums
    /// (orders 0…3 with the spectral weights replaced by 1) tracks the exact Airy sum: a
    /// check of the interfaces, phases and path difference, independent of the colour fit.
    #[test]
    fn airy_terms_match_the_exact_sum_at_one_wavelength() {
        let (film_ior, sub, d) = (1.33f32, 1.5f32, 500.0f32);
        for &cos in &[1.0f32, 0.7, 0.3] {
            for &lambda in &[450.0f64, 550.0, 650.0] {
                let (r12, ph12, cf) = interface(cos, film_ior).unwrap();
                let (r23, ph23, _) = interface(cf, sub / film_ior).unwrap();
                let opd = 2.0 * film_ior * d * cf;
                let mut ours = 0.0f64;
                for k in 0..2 {
                    let pi = std::f64::consts::PI;
                    let phase = pi - pi * ph12[k] as u8 as f64 + pi * ph23[k] as u8 as f64;
                    let (r12, r23) = (r12[k] as f64, r23[k] as f64);
                    let t121 = 1.0 - r12;
                    let r123 = r12 * r23;
                    let inside = t121 * t121 * r23 / (1.0 - r123);
                    let mut sum = r12 + inside;
                    let mut c = inside - t121;
                    // All orders (the module stops at 3: these terms shrink as (r12 r23)^m/2).
                    for m in 1..40 {
                        c *= r123.sqrt();
                        let m = m as f64;
                        let arg = std::f64::consts::TAU * m * opd as f64 / lambda + m * phase;
                        sum += 2.0 * c * arg.cos();
                    }
                    ours += 0.5 * sum;
                }
                let exact = airy_exact(cos, film_ior as f64, sub as f64, d as f64, lambda);
                assert!(
                    (ours - exact).abs() < 1e-4,
                    "{cos} {lambda}: {ours} vs {exact}"
                );
            }
        }
    }

    /// Values Blender 4.5's Cycles renders (a smooth Principled BSDF, black base, seen at
    /// normal incidence and at 60° by an orthographic camera under a white world of strength
    /// 1: the pixel is the reflectance): IOR 1.5, film IOR 1.33.
    #[test]
    fn matches_cycles() {
        let cases = [
            (250.0, 0.0, [0.046188, 0.025447, 0.006077]),
            (500.0, 0.0, [0.037087, 0.008976, 0.036142]),
            (800.0, 0.0, [0.004990, 0.031164, 0.021120]),
            (250.0, 60.0, [0.069811, 0.087445, 0.081555]),
            (500.0, 60.0, [0.031311, 0.082435, 0.064725]),
        ];
        for (d, angle, cycles) in cases {
            let film = ThinFilm {
                thickness: d,
                ior: 1.33,
            };
            let cos = (angle as f32).to_radians().cos();
            let f = thin_film_reflectance(cos, &film, 1.5);
            let want = Vec3::from(cycles);
            assert!(
                (f - want).abs().max_element() < 2e-4,
                "{d} {angle}: {f} vs {want}"
            );
        }
        // A film denser than a substrate of low index (Cycles: 0.25769, 0.16443, 0.09091).
        let film = ThinFilm {
            thickness: 400.0,
            ior: 1.8,
        };
        let f = thin_film_reflectance(1.0, &film, 1.1);
        assert!(
            (f - Vec3::new(0.257686, 0.164428, 0.090911))
                .abs()
                .max_element()
                < 2e-4
        );
    }

    /// The fit's transform evaluated directly (with a phase shift), as Belcour & Barla
    /// write it.
    fn direct_sensitivity(opd: f64, shift: f64) -> [f64; 3] {
        let w = std::f64::consts::TAU * opd * 1e-9;
        let mut out = [0.0; 3];
        for (k, (xyz, a, c, v)) in FIT.into_iter().enumerate() {
            let (a, c, v) = (a as f64, c as f64, v as f64);
            let scale = if k < 3 {
                a * (std::f64::consts::TAU * v).sqrt()
            } else {
                a
            };
            out[xyz] += scale * (c * w + shift).cos() * (-w * w * v).exp();
        }
        out.map(|x| x / 1.0685e-7)
    }

    #[test]
    fn orders_share_the_fit_evaluated_directly() {
        for &opd in &[0.0f32, 120.0, 665.0, 1330.0, 2400.0, 5000.0] {
            let fast = sensitivities(opd);
            for m in 1..4 {
                for (flip, shift) in [(1.0, 0.0), (-1.0, std::f64::consts::PI)] {
                    let want = direct_sensitivity(m as f64 * opd as f64, m as f64 * shift);
                    let sign = if m % 2 == 1 { flip } else { 1.0 };
                    for c in 0..3 {
                        let got = sign * fast[m - 1][c] as f64;
                        assert!(
                            (got - want[c]).abs() < 2e-5,
                            "{opd} {m} {shift}: {got} {want:?}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn a_partial_film_mixes_the_reflectances() {
        let (plain, film) = (Vec3::splat(0.04), Vec3::new(0.1, 0.0, 0.02));
        assert_eq!(weigh_film(plain, film, 1.0), film);
        assert_eq!(weigh_film(plain, film, 0.0), plain);
        assert!((weigh_film(plain, film, 0.5) - Vec3::new(0.07, 0.02, 0.03)).length() < 1e-6);
    }

    #[test]
    fn f0_scaling_is_the_identity_for_an_untinted_layer() {
        let f = Vec3::new(0.03, 0.2, 0.9);
        assert_eq!(scale_to_f0(f, Vec3::splat(0.04), 0.04), f);
        let half = scale_to_f0(Vec3::splat(0.04), Vec3::splat(0.02), 0.04);
        assert!((half - Vec3::splat(0.02)).length() < 1e-6);
        assert_eq!(scale_to_f0(Vec3::ONE, Vec3::ZERO, 0.04), Vec3::ONE);
    }
}
