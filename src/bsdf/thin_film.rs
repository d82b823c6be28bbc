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
//!
//! Blender 5's Cycles (`FilmModel::Blender5`) integrates over the CIE 1931 functions' Fourier
//! transform instead of the fit (`CieTable`), fades films under 1 nm, and puts the film on the
//! Principled BSDF's metal too (`ConductorFilm`: the conductor's complex reflection phases in
//! the same series).

use super::fresnel::F82Tint;
use crate::math::Vec3;

/// Films at most this thick (nm) are absent (Cycles' threshold on the Thin Film Thickness).
pub const MIN_THICKNESS: f32 = 0.1;

/// Below this thickness (nm) the film's index fades towards the ambient medium's.
const FADE_THICKNESS: f32 = 30.0;

/// Blender 5's `FADE_THICKNESS`.
const BLENDER5_FADE_THICKNESS: f32 = 1.0;

/// A film on a surface: thickness in nanometres, index of refraction, and whose Cycles
/// renders it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinFilm {
    pub thickness: f32,
    pub ior: f32,
    pub model: FilmModel,
}

impl ThinFilm {
    /// The film of a material's inputs; `None` when it is too thin to exist.
    pub fn new(thickness: f32, ior: f32, model: FilmModel) -> Option<ThinFilm> {
        (thickness.is_finite() && thickness > MIN_THICKNESS && ior.is_finite()).then(|| ThinFilm {
            thickness,
            ior: ior.max(1e-5),
            model,
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
    if film.model == FilmModel::Blender5 {
        return dielectric_reflectance_blender5(cos_i, film, substrate);
    }
    let film_ior = faded_ior(film, FADE_THICKNESS);
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

/// Which Cycles' film a material has.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FilmModel {
    /// Blender 4: the Gaussian fit of the colour matching functions, films under 30 nm
    /// fading, metals without a film.
    #[default]
    Blender4,
    /// Blender 5: the Fourier transform of the CIE 1931 functions themselves (`CieTable`),
    /// films under 1 nm fading, and a film on the Principled BSDF's metal too
    /// (`ConductorFilm`).
    Blender5,
}

/// The CIE 1931 2° colour matching functions x̄, ȳ, z̄ every 5 nm from 360 to 830 nm (CIE
/// 15:2004, table T.4).
const CIE_1931: [[f64; 3]; 95] = [
    [0.0001299, 0.000003917, 0.0006061],
    [0.0002321, 0.000006965, 0.001086],
    [0.0004149, 0.00001239, 0.001946],
    [0.0007416, 0.00002202, 0.003486],
    [0.001368, 0.000039, 0.006450001],
    [0.002236, 0.000064, 0.01054999],
    [0.004243, 0.00012, 0.02005001],
    [0.00765, 0.000217, 0.03621],
    [0.01431, 0.000396, 0.06785001],
    [0.02319, 0.00064, 0.1102],
    [0.04351, 0.00121, 0.2074],
    [0.07763, 0.00218, 0.3713],
    [0.13438, 0.004, 0.6456],
    [0.21477, 0.0073, 1.0390501],
    [0.2839, 0.0116, 1.3856],
    [0.3285, 0.01684, 1.62296],
    [0.34828, 0.023, 1.74706],
    [0.34806, 0.0298, 1.7826],
    [0.3362, 0.038, 1.77211],
    [0.3187, 0.048, 1.7441],
    [0.2908, 0.06, 1.6692],
    [0.2511, 0.0739, 1.5281],
    [0.19536, 0.09098, 1.28764],
    [0.1421, 0.1126, 1.0419],
    [0.09564, 0.13902, 0.8129501],
    [0.05795001, 0.1693, 0.6162],
    [0.03201, 0.20802, 0.46518],
    [0.0147, 0.2586, 0.3533],
    [0.0049, 0.323, 0.272],
    [0.0024, 0.4073, 0.2123],
    [0.0093, 0.503, 0.1582],
    [0.0291, 0.6082, 0.1117],
    [0.06327, 0.71, 0.07824999],
    [0.1096, 0.7932, 0.05725001],
    [0.1655, 0.862, 0.04216],
    [0.2257499, 0.9148501, 0.02984],
    [0.2904, 0.954, 0.0203],
    [0.3597, 0.9803, 0.0134],
    [0.4334499, 0.9949501, 0.008749999],
    [0.5120501, 1.0, 0.005749999],
    [0.5945, 0.995, 0.0039],
    [0.6784, 0.9786, 0.002749999],
    [0.7621, 0.952, 0.0021],
    [0.8425, 0.9154, 0.0018],
    [0.9163, 0.87, 0.001650001],
    [0.9786, 0.8163, 0.0014],
    [1.0263, 0.757, 0.0011],
    [1.0567, 0.6949, 0.001],
    [1.0622, 0.631, 0.0008],
    [1.0456, 0.5668, 0.0006],
    [1.0026, 0.503, 0.00034],
    [0.9384, 0.4412, 0.00024],
    [0.8544499, 0.381, 0.00019],
    [0.7514, 0.321, 0.0001],
    [0.6424, 0.265, 0.00005],
    [0.5419, 0.217, 0.00003],
    [0.4479, 0.175, 0.00002],
    [0.3608, 0.1382, 0.00001],
    [0.2835, 0.107, 0.0],
    [0.2187, 0.0816, 0.0],
    [0.1649, 0.061, 0.0],
    [0.1212, 0.04458, 0.0],
    [0.0874, 0.032, 0.0],
    [0.0636, 0.0232, 0.0],
    [0.04677, 0.017, 0.0],
    [0.0329, 0.01192, 0.0],
    [0.0227, 0.00821, 0.0],
    [0.01584, 0.005723, 0.0],
    [0.01135916, 0.004102, 0.0],
    [0.008110916, 0.002929, 0.0],
    [0.005790346, 0.002091, 0.0],
    [0.004109457, 0.001484, 0.0],
    [0.002899327, 0.001047, 0.0],
    [0.00204919, 0.00074, 0.0],
    [0.001439971, 0.00052, 0.0],
    [0.000999949, 0.0003611, 0.0],
    [0.000690079, 0.0002492, 0.0],
    [0.000476021, 0.0001719, 0.0],
    [0.000332301, 0.00012, 0.0],
    [0.000234826, 0.0000848, 0.0],
    [0.000166151, 0.00006, 0.0],
    [0.000117413, 0.0000424, 0.0],
    [0.0000830753, 0.00003, 0.0],
    [0.0000587065, 0.0000212, 0.0],
    [0.0000415099, 0.00001499, 0.0],
    [0.0000293533, 0.0000106, 0.0],
    [0.0000206738, 0.0000074657, 0.0],
    [0.0000145598, 0.0000052578, 0.0],
    [0.000010254, 0.0000037029, 0.0],
    [0.00000722146, 0.0000026078, 0.0],
    [0.00000508587, 0.0000018366, 0.0],
    [0.00000358165, 0.0000012934, 0.0],
    [0.00000252253, 0.00000091093, 0.0],
    [0.00000177651, 0.00000064153, 0.0],
    [0.00000125114, 0.00000045181, 0.0],
];

/// The first wavelength of `CIE_1931` and its step (nm).
const CIE_START: f64 = 360.0;
const CIE_STEP: f64 = 5.0;

/// Entries of the Fourier table: path differences 0 to `TABLE_SPAN` nm.
const TABLE_SIZE: usize = 512;

/// The path difference (nm) at the table's last entry, 60 µm / 2π.
const TABLE_SPAN: f32 = 60000.0 / std::f32::consts::TAU;

/// Frequencies (1/µm, π/60 apart from 0) at which the colour matching functions are sampled
/// before their discrete Fourier transform: twice the table's entries less two, so that the
/// transform of these real samples has `TABLE_SIZE` distinct values.
const SAMPLES: usize = 2 * TABLE_SIZE - 2;

/// Blender 5's spectral integration of a film's reflectance (Belcour & Barla's Fourier
/// reformulation, §4, over the CIE 1931 functions rather than a fit): the colour matching
/// functions, as densities over frequency ν = 1/λ, sampled every π/60 µm⁻¹ (a natural cubic
/// spline between the 5 nm values), their discrete Fourier transform, taken to linear
/// Rec. 709 (XYZ with the white of D65) and divided by its value at zero path difference so
/// that each channel of a flat spectrum is 1. Entry k holds the sensitivity at path
/// difference k · `TABLE_SPAN` / (`TABLE_SIZE` − 1) as (real, imaginary) parts; between
/// entries it is read linearly.
struct CieTable {
    entries: Vec<(Vec3, Vec3)>,
}

impl CieTable {
    fn get() -> &'static CieTable {
        static TABLE: std::sync::OnceLock<CieTable> = std::sync::OnceLock::new();
        TABLE.get_or_init(CieTable::build)
    }

    fn build() -> CieTable {
        let spline: [NaturalSpline; 3] =
            std::array::from_fn(|c| NaturalSpline::new(&CIE_1931.map(|row| row[c])));
        let step = std::f64::consts::PI / 60.0;
        let samples: Vec<[f64; 3]> = (0..SAMPLES)
            .map(|j| {
                let nu = (j as f64 * step).max(1e-40);
                let lambda = 1000.0 / nu;
                let x = (lambda - CIE_START) / CIE_STEP;
                std::array::from_fn(|c| spline[c].at(x) / (nu * nu))
            })
            .collect();
        let to_rgb = |xyz: [f64; 3]| {
            Vec3::new(
                (3.240_454_2 * xyz[0] - 1.537_138_5 * xyz[1] - 0.498_531_4 * xyz[2]) as f32,
                (-0.969_266 * xyz[0] + 1.876_010_8 * xyz[1] + 0.041_556 * xyz[2]) as f32,
                (0.055_643_4 * xyz[0] - 0.204_025_9 * xyz[1] + 1.057_225_2 * xyz[2]) as f32,
            )
        };
        let mut entries: Vec<(Vec3, Vec3)> = (0..TABLE_SIZE)
            .map(|k| {
                let (mut re, mut im) = ([0.0f64; 3], [0.0f64; 3]);
                for (j, s) in samples.iter().enumerate() {
                    let turn = (j * k) % SAMPLES;
                    let angle = -std::f64::consts::TAU * turn as f64 / SAMPLES as f64;
                    let (sin, cos) = angle.sin_cos();
                    for c in 0..3 {
                        re[c] += s[c] * cos;
                        im[c] += s[c] * sin;
                    }
                }
                (to_rgb(re), to_rgb(im))
            })
            .collect();
        let white = Vec3::ONE / entries[0].0;
        for (re, im) in &mut entries {
            *re *= white;
            *im *= white;
        }
        CieTable { entries }
    }

    /// The sensitivity (real, imaginary per channel) at path difference `opd` (nm), the
    /// last entry beyond the table.
    fn at(&self, opd: f32) -> (Vec3, Vec3) {
        let x = (opd / TABLE_SPAN).clamp(0.0, 1.0) * (TABLE_SIZE - 1) as f32;
        let i = (x as usize).min(TABLE_SIZE - 1);
        let j = (i + 1).min(TABLE_SIZE - 1);
        let t = x - i as f32;
        let (a, b) = (self.entries[i], self.entries[j]);
        (a.0 * (1.0 - t) + b.0 * t, a.1 * (1.0 - t) + b.1 * t)
    }
}

/// A natural cubic spline through values at the whole numbers 0 … n − 1, zero outside.
struct NaturalSpline {
    values: Vec<f64>,
    /// Second derivatives at the knots.
    curvature: Vec<f64>,
}

impl NaturalSpline {
    fn new(values: &[f64]) -> NaturalSpline {
        // The tridiagonal system m[i−1] + 4 m[i] + m[i+1] = 6 (y[i+1] − 2 y[i] + y[i−1]),
        // m = 0 at both ends, by the Thomas algorithm.
        let n = values.len();
        let mut curvature = vec![0.0; n];
        let mut diag = vec![4.0; n];
        let mut rhs = vec![0.0; n];
        for i in 1..n - 1 {
            rhs[i] = 6.0 * (values[i + 1] - 2.0 * values[i] + values[i - 1]);
        }
        for i in 2..n - 1 {
            let w = 1.0 / diag[i - 1];
            diag[i] -= w;
            rhs[i] -= w * rhs[i - 1];
        }
        for i in (1..n - 1).rev() {
            curvature[i] = (rhs[i] - curvature[i + 1]) / diag[i];
        }
        NaturalSpline {
            values: values.to_vec(),
            curvature,
        }
    }

    fn at(&self, x: f64) -> f64 {
        let n = self.values.len();
        if !(x >= 0.0 && x <= (n - 1) as f64) {
            return 0.0;
        }
        let i = (x.floor() as usize).min(n - 2);
        let t = x - i as f64;
        let (y0, y1) = (self.values[i], self.values[i + 1]);
        let (m0, m1) = (self.curvature[i], self.curvature[i + 1]);
        (1.0 - t) * y0
            + t * y1
            + ((1.0 - t).powi(3) - (1.0 - t)) * m0 / 6.0
            + (t.powi(3) - t) * m1 / 6.0
    }
}

/// The Airy series of one polarisation (Belcour & Barla eq. 10, orders 0…3) with Blender 5's
/// table, per channel: `r12` the top interface's reflectance, `r23` the bottom's, `opd` the
/// round trip's path difference (nm), `phasor` e^{iφ} of the round trip's reflection phase
/// (real and imaginary parts per channel).
fn airy_series_table(r12: f32, r23: Vec3, opd: f32, phasor: (Vec3, Vec3)) -> Vec3 {
    let table = CieTable::get();
    let t121 = 1.0 - r12;
    let r123 = r23 * r12;
    let amplitude = Vec3::new(r123.x.sqrt(), r123.y.sqrt(), r123.z.sqrt());
    let inside = t121 * t121 * r23 / (Vec3::ONE - r123);
    let mut sum = inside + Vec3::splat(r12);
    let mut c = inside - Vec3::splat(t121);
    let (mut re, mut im) = phasor;
    for m in 1..4 {
        c *= amplitude;
        let (s_re, s_im) = table.at(m as f32 * opd);
        sum += 2.0 * c * (re * s_re + im * s_im);
        (re, im) = (re * phasor.0 - im * phasor.1, re * phasor.1 + im * phasor.0);
    }
    sum
}

/// The film's index, faded towards the ambient medium's (1) in films thinner than `fade`
/// nm (a smoothstep).
fn faded_ior(film: &ThinFilm, fade: f32) -> f32 {
    if film.thickness < fade {
        let t = (film.thickness / fade).clamp(0.0, 1.0);
        1.0 + (film.ior - 1.0) * (t * t * (3.0 - 2.0 * t))
    } else {
        film.ior
    }
}

/// Blender 5's `thin_film_reflectance` on a dielectric.
fn dielectric_reflectance_blender5(cos_i: f32, film: &ThinFilm, substrate: f32) -> Vec3 {
    let film_ior = faded_ior(film, BLENDER5_FADE_THICKNESS);
    let Some((r12, flip12, cos_film)) = interface(cos_i, film_ior) else {
        return Vec3::ONE;
    };
    let Some((r23, flip23, _)) = interface(cos_film, substrate / film_ior) else {
        return Vec3::ONE;
    };
    let opd = 2.0 * film_ior * film.thickness * cos_film;
    let mut rgb = Vec3::ZERO;
    for k in 0..2 {
        // The round trip's phase: π − φ₁₂ + φ₂₃, each φ 0 or π.
        let turn = if flip12[k] == flip23[k] { -1.0 } else { 1.0 };
        let phasor = (Vec3::splat(turn), Vec3::ZERO);
        rgb += 0.5 * airy_series_table(r12[k], Vec3::splat(r23[k]), opd, phasor);
    }
    rgb.clamp(Vec3::ZERO, Vec3::ONE)
}

/// Blender 5's film on the Principled BSDF's metal: the F82-tint metal taken as a conductor
/// of complex index n + ik per channel (Gulbrandsen 2014, "Artist Friendly Metallic Fresnel",
/// its reflectivity r the metal's F0 and its edge tint g the model's value at 82°), whose
/// reflection phases (Born & Wolf §14.4.1) shift the film's interference while the
/// reflectance under the film stays the F82-tint model's, its F0 that of n + ik relative to
/// the film.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConductorFilm {
    film: ThinFilm,
    n: Vec3,
    k: Vec3,
    f82: Vec3,
}

impl ConductorFilm {
    /// The film over an F82-tint metal.
    pub fn new(film: ThinFilm, metal: &F82Tint) -> ConductorFilm {
        let f82 = metal.eval(1.0 / 7.0);
        let channel = |f0: f32, g: f32| {
            let r = f0.min(0.999);
            let root = r.sqrt();
            let lo = (1.0 + root) / (1.0 - root);
            let n = lo + ((1.0 - r) / (1.0 + r) - lo) * g;
            let k2 = (r * (n + 1.0) * (n + 1.0) - (n - 1.0) * (n - 1.0)) / (1.0 - r);
            (n, k2.max(0.0).sqrt())
        };
        let [(nx, kx), (ny, ky), (nz, kz)] = [0, 1, 2].map(|c| channel(metal.f0[c], f82[c]));
        ConductorFilm {
            film,
            n: Vec3::new(nx, ny, nz),
            k: Vec3::new(kx, ky, kz),
            f82,
        }
    }

    /// The reflectance (linear Rec. 709, in [0, 1]) at cosine `cos_i` from a medium of
    /// index 1.
    pub fn reflectance(&self, cos_i: f32) -> Vec3 {
        let cos_i = cos_i.clamp(1e-6, 1.0);
        let film_ior = faded_ior(&self.film, BLENDER5_FADE_THICKNESS);
        let Some((r12, flip12, cos_film)) = interface(cos_i, film_ior) else {
            return Vec3::ONE;
        };
        let n = self.n / film_ior;
        let k2 = (self.k / film_ior) * (self.k / film_ior);
        let one = Vec3::ONE;
        let f0 = ((n - one) * (n - one) + k2) / ((n + one) * (n + one) + k2);
        let r23 = F82Tint::from_f82(f0, self.f82).eval(cos_film);
        let phasors = conductor_phasors(cos_film, film_ior, self.n, self.k);
        let opd = 2.0 * film_ior * self.film.thickness * cos_film;
        let mut rgb = Vec3::ZERO;
        for p in 0..2 {
            let turn = if flip12[p] { 1.0 } else { -1.0 };
            let (re, im) = phasors[p];
            rgb += 0.5 * airy_series_table(r12[p], r23, opd, (re * turn, im * turn));
        }
        rgb.clamp(Vec3::ZERO, Vec3::ONE)
    }
}

/// The phases of the waves a conductor of index n + ik reflects into a medium of index
/// `eta1`, light arriving at cosine `cos` (Born & Wolf §14.4.1), as unit phasors e^{iφ}
/// (real, imaginary per channel) for s and p polarisation; their signs agree with
/// `interface`'s on a dielectric (k = 0).
fn conductor_phasors(cos: f32, eta1: f32, n: Vec3, k: Vec3) -> [(Vec3, Vec3); 2] {
    let n2_k2 = n * n - k * k;
    let two_nk = 2.0 * n * k;
    let t1 = n2_k2 - Vec3::splat(eta1 * eta1 * (1.0 - cos * cos));
    let t2 = (t1 * t1 + two_nk * two_nk).powf(0.5);
    let u2 = (0.5 * (t2 + t1)).max(Vec3::ZERO);
    let v2 = (0.5 * (t2 - t1)).max(Vec3::ZERO);
    let (u, v) = (u2.powf(0.5), v2.powf(0.5));
    let unit = |re: Vec3, im: Vec3| {
        let len = (re * re + im * im).powf(0.5);
        let pick = |l: f32, a: f32, fallback: f32| if l > 0.0 { a / l } else { fallback };
        (
            Vec3::new(
                pick(len.x, re.x, 1.0),
                pick(len.y, re.y, 1.0),
                pick(len.z, re.z, 1.0),
            ),
            Vec3::new(
                pick(len.x, im.x, 0.0),
                pick(len.y, im.y, 0.0),
                pick(len.z, im.z, 0.0),
            ),
        )
    };
    let ec = eta1 * cos;
    let s = unit(Vec3::splat(ec * ec) - u2 - v2, -2.0 * ec * v);
    let mag = (n * n + k * k) * cos;
    let p = unit(
        mag * mag - eta1 * eta1 * (u2 + v2),
        2.0 * ec * (two_nk * u - n2_k2 * v),
    );
    [s, p]
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
                    model: FilmModel::Blender4,
                },
                ThinFilm {
                    thickness: 0.2,
                    ior: 1.33,
                    model: FilmModel::Blender4,
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
        assert!(ThinFilm::new(0.0, 1.33, FilmModel::Blender4).is_none());
        assert!(ThinFilm::new(MIN_THICKNESS, 1.33, FilmModel::Blender5).is_none());
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
                            model: FilmModel::Blender4,
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
                model: FilmModel::Blender4,
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
            model: FilmModel::Blender4,
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

    /// Blender 5's film: a film of index 1 is no film (the table's white is each channel's
    /// 1), on a dielectric and on a metal (Gulbrandsen's n + ik gives back the metal's F0, so
    /// the F82 tint under no film is the metal's own).
    #[test]
    fn blender5_invisible_films_give_the_plain_reflectance() {
        let (re, im) = CieTable::get().at(0.0);
        assert!((re - Vec3::ONE).abs().max_element() < 1e-6 && im.abs().max_element() < 1e-6);
        let none = ThinFilm {
            thickness: 500.0,
            ior: 1.0,
            model: FilmModel::Blender5,
        };
        let metal = F82Tint::new(Vec3::new(0.9, 0.6, 0.3), Vec3::new(0.8, 0.9, 1.0));
        let on_metal = ConductorFilm::new(none, &metal);
        for &cos in &[1.0f32, 0.8, 0.5, 0.2] {
            let f = thin_film_reflectance(cos, &none, 1.5);
            let plain = crate::bsdf::fresnel::fresnel_dielectric(cos, 1.5);
            assert!(
                (f - Vec3::splat(plain)).abs().max_element() < 1e-5,
                "{cos} {f}"
            );
            let m = on_metal.reflectance(cos);
            assert!(
                (m - metal.eval(cos)).abs().max_element() < 1e-3,
                "{cos} {m}"
            );
        }
    }

    /// On a conductor of no extinction the reflection phases are a dielectric's (0 or π, the
    /// same sign as `interface`'s amplitude ratios).
    #[test]
    fn conductor_phases_reduce_to_a_dielectrics() {
        for &cos in &[1.0f32, 0.7, 0.3] {
            for &n in &[1.2f32, 2.0, 0.8] {
                let Some((_, flips, _)) = interface(cos, n) else {
                    continue;
                };
                let [s, p] = conductor_phasors(cos, 1.0, Vec3::splat(n), Vec3::ZERO);
                for (k, (re, im)) in [s, p].into_iter().enumerate() {
                    let want = if flips[k] { -1.0 } else { 1.0 };
                    assert!(
                        (re.x - want).abs() < 1e-4 && im.x.abs() < 1e-4,
                        "{cos} {n} {k}"
                    );
                }
            }
        }
    }

    #[test]
    fn blender5_reflectances_stay_in_the_unit_interval() {
        let metal = F82Tint::new(Vec3::new(0.95, 0.64, 0.54), Vec3::new(1.0, 0.7, 0.5));
        for t in 0..40 {
            for &ior in &[1.1f32, 1.33, 1.8, 2.5] {
                let film = ThinFilm {
                    thickness: 0.5 + 37.0 * t as f32,
                    ior,
                    model: FilmModel::Blender5,
                };
                let on_metal = ConductorFilm::new(film, &metal);
                for c in 0..20 {
                    let cos = (c as f32 + 0.5) / 20.0;
                    for f in [
                        thin_film_reflectance(cos, &film, 1.5),
                        on_metal.reflectance(cos),
                    ] {
                        assert!(f.is_finite() && f.min_element() >= 0.0 && f.max_element() <= 1.0);
                    }
                }
            }
        }
    }
}
