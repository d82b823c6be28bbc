//! Blender's Sky Texture in its Nishita model, the default sky of Blender 2.90–4.5: sunlight
//! scattered once by air (Rayleigh) and by dust (Mie) on its way through a spherical
//! atmosphere, dimmed by ozone, after Nishita, Sirai, Tadamura & Nakamae (1993), "Display of the
//! Earth taking into account atmospheric scattering". It is evaluated the way Cycles evaluates
//! it, so that a Blender sky lights a scene alike in both: the scattering is integrated per
//! wavelength (21 from 380 to 780 nm) into CIE XYZ, tabulated over azimuth and the square root
//! of elevation (more rows near the horizon), looked up bilinearly, faded to black below the
//! horizon and turned into linear Rec. 709 RGB. The sun disc is apart: `sun` gives its
//! direction, angular size and the irradiance it sends, so the renderer can sample it as a sun
//! light (a disc 0.5° wide is too small to be found in an environment map).
//!
//! Directions are in Blender's world frame (Z up). Units are Cycles': the sky's radiance for a
//! Background strength of 1.

use crate::math::Vec3;
use rayon::prelude::*;
use std::f32::consts::{FRAC_PI_2, PI, TAU};

/// The sky's settings as Blender's Sky Texture node holds them (radians, metres, factors).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NishitaSettings {
    pub sun_elevation: f32,
    pub sun_rotation: f32,
    /// Angular diameter of the sun disc.
    pub sun_size: f32,
    pub sun_intensity: f32,
    pub sun_disc: bool,
    pub altitude: f32,
    pub air: f32,
    pub dust: f32,
    pub ozone: f32,
}

impl Default for NishitaSettings {
    /// Blender's defaults for a new Sky Texture node.
    fn default() -> Self {
        NishitaSettings {
            sun_elevation: 15f32.to_radians(),
            sun_rotation: 0.0,
            sun_size: 0.545f32.to_radians(),
            sun_intensity: 1.0,
            sun_disc: true,
            altitude: 0.0,
            air: 1.0,
            dust: 1.0,
            ozone: 1.0,
        }
    }
}

/// The sun as a light: the direction towards it, its angular diameter and the irradiance (RGB,
/// W/m² in Cycles' units) it gives a surface facing it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunDisc {
    pub direction: Vec3,
    pub angle: f32,
    pub irradiance: Vec3,
}

/// A Nishita sky ready for lookups.
#[derive(Clone, Debug)]
pub struct NishitaSky {
    /// CIE XYZ radiance, `TABLE_WIDTH` × `TABLE_HEIGHT`, row 0 on the horizon.
    table: Vec<Vec3>,
    sun_elevation: f32,
    /// The rotation as Cycles' kernel reads it: 2π − the node's rotation, in [0, 2π).
    sun_rotation: f32,
    sun_size: f32,
    sun_intensity: f32,
    sun_disc: bool,
    /// XYZ radiance of the sun disc at its lowest and highest point above the horizon.
    sun_bottom: Vec3,
    sun_top: Vec3,
}

const TABLE_WIDTH: usize = 512;
const TABLE_HEIGHT: usize = 128;

// The atmosphere.
const EARTH_RADIUS: f32 = 6360e3;
const ATMOSPHERE_RADIUS: f32 = 6420e3;
const RAYLEIGH_SCALE_HEIGHT: f32 = 8e3;
const MIE_SCALE_HEIGHT: f32 = 1.2e3;
/// Mie scattering coefficient (1/m); extinction is `MIE_EXTINCTION` times it.
const MIE_SCATTERING: f32 = 2e-5;
const MIE_EXTINCTION: f32 = 1.11;
/// Anisotropy of the dust's phase function.
const MIE_G: f32 = 0.76;
/// Segments of the view ray.
const VIEW_STEPS: usize = 32;

// Spectral data at 380, 400, ..., 780 nm.
const WAVELENGTHS: usize = 21;
const WAVELENGTH_STEP: f32 = 20.0;
/// Solar irradiance above the atmosphere (W m⁻² nm⁻¹).
const SOLAR_IRRADIANCE: [f32; WAVELENGTHS] = [
    1.457_568_3,
    1.565_963_1,
    1.651_484_5,
    1.714_962_4,
    1.757_979_8,
    1.782_564,
    1.790_951_1,
    1.785_415_5,
    1.768_155_5,
    1.741_220_7,
    1.706_471_3,
    1.665_560_9,
    1.619_934_4,
    1.570_836,
    1.519_323_4,
    1.466_284_9,
    1.412_458_5,
    1.358_449_6,
    1.304_749_1,
    1.251_749_6,
    1.199_76,
];
/// Rayleigh scattering coefficient of air at sea level (1/m).
const RAYLEIGH_SCATTERING: [f32; WAVELENGTHS] = [
    5.424_82e-5,
    4.418_55e-5,
    3.635_152e-5,
    3.017_929e-5,
    2.526_32e-5,
    2.130_859e-5,
    1.809_838e-5,
    1.547_057e-5,
    1.330_285e-5,
    1.150_185e-5,
    9.995_574e-6,
    8.728e-6,
    7.655_137e-6,
    6.742_172e-6,
    5.961_341e-6,
    5.290_346e-6,
    4.711_157e-6,
    4.209_105e-6,
    3.772_184e-6,
    3.390_513e-6,
    3.055_915e-6,
];
/// Ozone absorption coefficient at the peak of its layer (1/m).
const OZONE_ABSORPTION: [f32; WAVELENGTHS] = [
    3.251_268e-9,
    5.853_954e-9,
    1.977_191e-8,
    7.309_569e-8,
    2.008_456e-7,
    4.038_396e-7,
    6.355_134e-7,
    9.670_704e-7,
    1.547_974e-6,
    2.090_386e-6,
    2.461_281e-6,
    2.735_513e-6,
    2.151_259e-6,
    1.590_518e-6,
    1.123_562e-6,
    7.352_755e-7,
    4.645_013e-7,
    3.309_608e-7,
    2.251_261e-7,
    1.487_913e-7,
    1.682_862e-7,
];
/// CIE 1931 colour-matching functions x̄, ȳ, z̄.
const CIE_XYZ: [[f32; 3]; WAVELENGTHS] = [
    [0.001368, 0.000039, 0.006450001],
    [0.01431, 0.000396, 0.06785001],
    [0.13438, 0.004, 0.6456],
    [0.34828, 0.023, 1.74706],
    [0.2908, 0.06, 1.6692],
    [0.09564, 0.13902, 0.8129501],
    [0.0049, 0.323, 0.272],
    [0.06327, 0.71, 0.07824999],
    [0.2904, 0.954, 0.0203],
    [0.5945, 0.995, 0.0039],
    [0.9163, 0.87, 0.001650001],
    [1.0622, 0.631, 0.0008],
    [0.8544499, 0.381, 0.00019],
    [0.4479, 0.175, 0.00002],
    [0.1649, 0.061, 0.0],
    [0.04677, 0.017, 0.0],
    [0.01135916, 0.004102, 0.0],
    [0.002899327, 0.001047, 0.0],
    [0.0006900786, 0.0002492, 0.0],
    [0.0001661505, 0.00006, 0.0],
    [0.00004150994, 0.00001499, 0.0],
];

/// Optical depth towards the sun by 8-point Gauss–Laguerre quadrature over the ray to the top
/// of the atmosphere (densities fall off about exponentially along it): nodes as fractions of
/// the ray (Laguerre's nodes / 25) and weights that already hold the e^x factor (w·e^x / 25),
/// Cycles' choice, kept so the two agree.
const QUADRATURE_NODES: [f32; 8] = [
    0.006_811_185,
    0.036_148_07,
    0.090_043_47,
    0.170_668,
    0.281_836_2,
    0.430_340_6,
    0.629_627_1,
    0.914_525_3,
];
const QUADRATURE_WEIGHTS: [f32; 8] = [
    0.017_508_94,
    0.041_354_77,
    0.066_788_39,
    0.095_076_99,
    0.128_341_6,
    0.170_743,
    0.232_723_3,
    0.356_249,
];

/// Linear Rec. 709 RGB from CIE XYZ (D65), negative values clamped as Cycles does.
pub fn xyz_to_rec709(xyz: Vec3) -> Vec3 {
    Vec3::new(
        3.240_454_2 * xyz.x - 1.537_138_5 * xyz.y - 0.498_531_4 * xyz.z,
        -0.969_266 * xyz.x + 1.876_010_8 * xyz.y + 0.041_556 * xyz.z,
        0.055_643_4 * xyz.x - 0.204_025_9 * xyz.y + 1.057_225_2 * xyz.z,
    )
    .max(Vec3::ZERO)
}

/// Relative densities of air, dust and ozone at `height` metres above sea level.
fn densities(height: f32) -> Vec3 {
    let ozone = if (10e3..25e3).contains(&height) {
        height / 15e3 - 2.0 / 3.0
    } else if (25e3..40e3).contains(&height) {
        8.0 / 3.0 - height / 15e3
    } else {
        0.0
    };
    Vec3::new(
        (-height / RAYLEIGH_SCALE_HEIGHT).exp(),
        (-height / MIE_SCALE_HEIGHT).exp(),
        ozone,
    )
}

/// Distance from `origin` (inside the atmosphere) along unit `dir` to its outer boundary.
fn distance_to_space(origin: Vec3, dir: Vec3) -> f32 {
    let b = dir.dot(origin);
    let c = origin.length_squared() - ATMOSPHERE_RADIUS * ATMOSPHERE_RADIUS;
    -b + (b * b - c).max(0.0).sqrt()
}

/// Whether the line from `p` along `dir` (pointing downwards) meets the Earth.
fn earth_in_the_way(p: Vec3, dir: Vec3) -> bool {
    if dir.z >= 0.0 {
        return false;
    }
    let b = dir.dot(p);
    b * b - (p.length_squared() - EARTH_RADIUS * EARTH_RADIUS) >= 0.0
}

/// Air, dust and ozone optical depth (unscaled by the densities' factors) from `origin` to space
/// along `dir`.
fn optical_depth_to_space(origin: Vec3, dir: Vec3) -> Vec3 {
    let length = distance_to_space(origin, dir);
    let mut depth = Vec3::ZERO;
    for (node, weight) in QUADRATURE_NODES.iter().zip(QUADRATURE_WEIGHTS) {
        let p = origin + dir * (node * length);
        depth += densities(p.length() - EARTH_RADIUS) * weight;
    }
    depth * length
}

fn rayleigh_phase(mu: f32) -> f32 {
    3.0 / (16.0 * PI) * (1.0 + mu * mu)
}

/// Cornette–Shanks phase function of the dust.
fn mie_phase(mu: f32) -> f32 {
    let g2 = MIE_G * MIE_G;
    3.0 * (1.0 - g2) * (1.0 + mu * mu)
        / (8.0 * PI * (2.0 + g2) * (1.0 + g2 - 2.0 * MIE_G * mu).powf(1.5))
}

fn spectrum_to_xyz(spectrum: &[f32; WAVELENGTHS]) -> Vec3 {
    let mut xyz = Vec3::ZERO;
    for (s, cmf) in spectrum.iter().zip(CIE_XYZ) {
        xyz += Vec3::from(cmf) * *s;
    }
    xyz * WAVELENGTH_STEP
}

/// Direction of latitude `lat` (elevation) and longitude `lon` in the table's frame.
fn geographic(lat: f32, lon: f32) -> Vec3 {
    Vec3::new(lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin())
}

/// Light scattered once towards `eye` along the view ray `dir`, XYZ.
fn single_scattering(eye: Vec3, dir: Vec3, to_sun: Vec3, scale: Vec3) -> Vec3 {
    let step = distance_to_space(eye, dir) / VIEW_STEPS as f32;
    let mu = dir.dot(to_sun);
    let (phase_air, phase_dust) = (rayleigh_phase(mu), mie_phase(mu));
    let mut spectrum = [0.0f32; WAVELENGTHS];
    let mut view_depth = Vec3::ZERO;
    for i in 0..VIEW_STEPS {
        // Each segment is evaluated at its middle.
        let p = eye + dir * (step * (i as f32 + 0.5));
        let density = scale * densities(p.length() - EARTH_RADIUS);
        view_depth += density * step;
        if earth_in_the_way(p, to_sun) {
            continue;
        }
        let depth = view_depth + scale * optical_depth_to_space(p, to_sun);
        for (l, s) in spectrum.iter_mut().enumerate() {
            let extinction = depth.x * RAYLEIGH_SCATTERING[l]
                + depth.y * MIE_EXTINCTION * MIE_SCATTERING
                + depth.z * OZONE_ABSORPTION[l];
            let scattering = density.x * RAYLEIGH_SCATTERING[l] * phase_air
                + density.y * MIE_SCATTERING * phase_dust;
            *s += (-extinction).exp() * scattering * SOLAR_IRRADIANCE[l] * step;
        }
    }
    spectrum_to_xyz(&spectrum)
}

/// Radiance (XYZ) of the sun disc seen along `dir` from `eye`: the sunlight that reaches the
/// ground through air and dust (ozone is left out, as in Cycles), spread over the disc's solid
/// angle.
fn sun_radiance(eye: Vec3, dir: Vec3, scale: Vec3, solid_angle: f32) -> Vec3 {
    let depth = optical_depth_to_space(eye, dir);
    let mut spectrum = [0.0f32; WAVELENGTHS];
    for (l, s) in spectrum.iter_mut().enumerate() {
        let extinction = RAYLEIGH_SCATTERING[l] * depth.x * scale.x
            + MIE_EXTINCTION * MIE_SCATTERING * depth.y * scale.y;
        *s = SOLAR_IRRADIANCE[l] * (-extinction).exp() / solid_angle;
    }
    spectrum_to_xyz(&spectrum)
}

/// Angle between two unit vectors, accurate for small angles.
pub(crate) fn angle_between(a: Vec3, b: Vec3) -> f32 {
    2.0 * (a - b).length().atan2((a + b).length())
}

/// The sun's elevation in [−π/2, π/2] and its rotation as Cycles' kernel reads it (2π − the
/// node's rotation, in (0, 2π]): Blender lets the sun go round, so an elevation past the zenith
/// comes back down on the other side, the rotation turned by π.
pub(crate) fn sun_position(settings: &NishitaSettings) -> (f32, f32) {
    let mut elevation = settings.sun_elevation % TAU;
    let mut rotation = settings.sun_rotation;
    if elevation.abs() >= PI {
        elevation -= 2.0 * PI * elevation.signum();
    }
    if elevation.abs() >= FRAC_PI_2 {
        elevation = PI * elevation.signum() - elevation;
        rotation += PI;
    }
    (elevation, TAU - rotation.rem_euclid(TAU))
}

/// Bilinear lookup at (u, v) ∈ [0, 1]² in a `width` × `height` table of texels centred at
/// ((i + ½)/width, (j + ½)/height), edges extended (Cycles' linear image lookup).
pub(crate) fn bilinear(table: &[Vec3], width: usize, height: usize, u: f32, v: f32) -> Vec3 {
    let texel = |coordinate: f32, size: usize| {
        let f = coordinate * size as f32 - 0.5;
        let i = f.floor();
        let clamp = |k: f32| (k.max(0.0) as usize).min(size - 1);
        (clamp(i), clamp(i + 1.0), f - i)
    };
    let (x0, x1, fx) = texel(u, width);
    let (y0, y1, fy) = texel(v, height);
    let row = |y: usize| table[y * width + x0] * (1.0 - fx) + table[y * width + x1] * fx;
    row(y0) * (1.0 - fy) + row(y1) * fy
}

/// Cycles' limb darkening of the sun disc at angle `gamma` from its centre (`half` its angular
/// radius): 1 at the centre, 0.4 at the rim.
pub(crate) fn limb_darkening(gamma: f32, half: f32) -> f32 {
    1.0 - 0.6 * (1.0 - (1.0 - (gamma / half).powi(2)).sqrt())
}

/// The irradiance a disc of angular diameter `size` centred on unit `centre` gives a surface
/// facing it: `radiance` integrated over the disc, cosine-weighted from its centre (48 rings of
/// 96 cells).
fn disc_irradiance(centre: Vec3, size: f32, radiance: impl Fn(Vec3) -> Vec3) -> Vec3 {
    let frame = crate::math::Frame::from_normal(centre);
    let half = 0.5 * size;
    const RINGS: usize = 48;
    const SECTORS: usize = 96;
    let mut irradiance = Vec3::ZERO;
    for i in 0..RINGS {
        let (g0, g1) = (
            half * i as f32 / RINGS as f32,
            half * (i + 1) as f32 / RINGS as f32,
        );
        let gamma = 0.5 * (g0 + g1);
        // Solid angle of one cell of the ring, times the cosine to the disc's centre.
        let cell = (g0.cos() - g1.cos()) * TAU / SECTORS as f32 * gamma.cos();
        for j in 0..SECTORS {
            let phi = TAU * (j as f32 + 0.5) / SECTORS as f32;
            let local = Vec3::new(
                gamma.sin() * phi.cos(),
                gamma.sin() * phi.sin(),
                gamma.cos(),
            );
            irradiance += radiance(frame.to_world(local)) * cell;
        }
    }
    irradiance
}

/// Unit direction towards the sun at `elevation` and the kernel's `rotation` (Cycles' kernel:
/// the tables' sun azimuth turned by the rotation).
pub(crate) fn sun_towards(elevation: f32, rotation: f32) -> Vec3 {
    let r = rotation - FRAC_PI_2;
    Vec3::new(
        -elevation.cos() * r.cos(),
        -elevation.cos() * r.sin(),
        elevation.sin(),
    )
}

/// The disc of angular diameter `size` about `centre` as a sun light: its irradiance
/// (`disc_irradiance` of `radiance`); `None` when it is not `shown`, has no size or none of it
/// shines.
pub(crate) fn disc_light(
    shown: bool,
    centre: Vec3,
    size: f32,
    radiance: impl Fn(Vec3) -> Vec3,
) -> Option<SunDisc> {
    if !shown || size <= 0.0 {
        return None;
    }
    let irradiance = disc_irradiance(centre, size, radiance);
    (irradiance.max_element() > 0.0).then_some(SunDisc {
        direction: centre,
        angle: size,
        irradiance,
    })
}

impl NishitaSky {
    /// Tabulate the sky for `settings`: 256 × 128 view rays of 32 steps, each step with a ray
    /// to the sun, spread over rayon's threads.
    pub fn new(settings: &NishitaSettings) -> NishitaSky {
        let (elevation, rotation) = sun_position(settings);
        // Below a metre the model misbehaves; above 60 km is space.
        let altitude = settings.altitude.clamp(1.0, 59_999.0);
        let eye = Vec3::new(0.0, 0.0, EARTH_RADIUS + altitude);
        let scale = Vec3::new(settings.air, settings.dust, settings.ozone);
        let to_sun = geographic(elevation, 0.0);

        let half_row = FRAC_PI_2 / TABLE_HEIGHT as f32 / 2.0;
        let mut table = vec![Vec3::ZERO; TABLE_WIDTH * TABLE_HEIGHT];
        table
            .par_chunks_mut(TABLE_WIDTH)
            .enumerate()
            .for_each(|(y, row)| {
                let t = y as f32 / TABLE_HEIGHT as f32;
                let latitude = (FRAC_PI_2 + half_row) * t * t;
                // The sky is symmetric about the sun's azimuth: compute half, mirror the rest.
                for x in 0..TABLE_WIDTH / 2 {
                    let longitude = TAU / TABLE_WIDTH as f32 * x as f32 - PI;
                    let dir = geographic(latitude, longitude);
                    let xyz = single_scattering(eye, dir, to_sun, scale);
                    row[x] = xyz;
                    row[TABLE_WIDTH - 1 - x] = xyz;
                }
            });

        let half = 0.5 * settings.sun_size;
        let solid_angle = TAU * (1.0 - half.cos());
        let sun_at = |e: f32| sun_radiance(eye, geographic(e.max(0.0), 0.0), scale, solid_angle);
        NishitaSky {
            table,
            sun_elevation: elevation,
            sun_rotation: rotation,
            sun_size: settings.sun_size,
            sun_intensity: settings.sun_intensity,
            sun_disc: settings.sun_disc,
            sun_bottom: sun_at(elevation - half),
            sun_top: sun_at(elevation + half),
        }
    }

    fn lookup(&self, u: f32, v: f32) -> Vec3 {
        bilinear(&self.table, TABLE_WIDTH, TABLE_HEIGHT, u, v)
    }

    /// Radiance of the sky along unit `dir`, without the sun disc: the table above the horizon,
    /// the horizon's row fading to black by 0.4 below it.
    pub fn sky_radiance(&self, dir: Vec3) -> Vec3 {
        let u = (-dir.y.atan2(dir.x) - FRAC_PI_2 + self.sun_rotation) / TAU;
        let u = u - u.floor();
        if dir.z >= 0.0 {
            let elevation = FRAC_PI_2 - dir.z.min(1.0).acos();
            xyz_to_rec709(self.lookup(u, (elevation / FRAC_PI_2).max(0.0).sqrt()))
        } else if dir.z < -0.4 {
            Vec3::ZERO
        } else {
            let fade = (1.0 + 2.5 * dir.z).powi(3);
            xyz_to_rec709(self.lookup(u, -0.5) * fade)
        }
    }

    /// Unit direction towards the centre of the sun.
    pub fn sun_direction(&self) -> Vec3 {
        sun_towards(self.sun_elevation, self.sun_rotation)
    }

    /// Radiance of the sun disc along unit `dir` (zero outside it and below the horizon):
    /// interpolated between its bottom and top colours by elevation, darkened towards the limb.
    pub fn sun_radiance(&self, dir: Vec3) -> Vec3 {
        let half = 0.5 * self.sun_size;
        let gamma = angle_between(dir, self.sun_direction());
        if !self.sun_disc || dir.z < 0.0 || gamma >= half {
            return Vec3::ZERO;
        }
        let elevation = FRAC_PI_2 - dir.z.min(1.0).acos();
        let (bottom, top) = (self.sun_elevation - half, self.sun_elevation + half);
        let t = if bottom > 0.0 {
            (elevation - self.sun_elevation) / self.sun_size + 0.5
        } else if top > 0.0 {
            elevation / top
        } else {
            return Vec3::ZERO;
        };
        let xyz = self.sun_bottom.lerp(self.sun_top, t) * self.sun_intensity;
        xyz_to_rec709(xyz) * limb_darkening(gamma, half)
    }

    /// The sun disc as a light (`None` without a disc or below the horizon): the irradiance is
    /// `sun_radiance` integrated over the disc, cosine-weighted from its centre.
    pub fn sun(&self) -> Option<SunDisc> {
        let shown = self.sun_disc && self.sun_intensity > 0.0;
        disc_light(shown, self.sun_direction(), self.sun_size, |d| {
            self.sun_radiance(d)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sky is brightest near the horizon below the sun and bluer overhead than at the
    /// horizon; black well below the horizon; symmetric about the sun's azimuth.
    #[test]
    fn sky_has_the_shape_of_a_clear_day() {
        let sky = NishitaSky::new(&NishitaSettings::default());
        let sun = sky.sun_direction();
        assert!((sun.z - 15f32.to_radians().sin()).abs() < 1e-5);
        // Rotation 0 puts the sun towards +Y, as in Blender.
        assert!(sun.y > 0.9 && sun.x.abs() < 1e-5, "{sun}");
        let zenith = sky.sky_radiance(Vec3::Z);
        let horizon_away = sky.sky_radiance(Vec3::new(0.0, -1.0, 0.01).normalize());
        assert!(zenith.z > zenith.x, "zenith is blue: {zenith}");
        assert!(horizon_away.min_element() > 0.0);
        let mirrored = |d: Vec3| Vec3::new(-d.x, d.y, d.z);
        let d = Vec3::new(0.5, 0.3, 0.4).normalize();
        let (a, b) = (sky.sky_radiance(d), sky.sky_radiance(mirrored(d)));
        assert!(
            (a - b).abs().max_element() <= 1e-4 * a.max_element(),
            "{a} {b}"
        );
        assert_eq!(
            sky.sky_radiance(Vec3::new(0.0, 0.5, -0.8).normalize()),
            Vec3::ZERO
        );
    }

    /// The disc's irradiance is its radiance times its solid angle, within what limb darkening
    /// takes away (a uniform disc of the same centre radiance gives more).
    #[test]
    fn sun_irradiance_integrates_the_disc() {
        let settings = NishitaSettings {
            sun_elevation: 40f32.to_radians(),
            ..NishitaSettings::default()
        };
        let sky = NishitaSky::new(&settings);
        let sun = sky.sun().expect("a sun above the horizon");
        let centre = sky.sun_radiance(sky.sun_direction());
        let half = 0.5 * settings.sun_size;
        let uniform = centre * TAU * (1.0 - half.cos());
        // ∫(1 − 0.6(1 − cos-like)) over a disc: 1 − 0.6 · (1 − 2/3) = 0.8 of the uniform disc.
        let ratio = sun.irradiance.y / uniform.y;
        assert!((ratio - 0.8).abs() < 0.01, "{ratio}");
        let below = NishitaSky::new(&NishitaSettings {
            sun_elevation: -5f32.to_radians(),
            ..settings
        });
        assert!(below.sun().is_none());
        let off = NishitaSky::new(&NishitaSettings {
            sun_disc: false,
            ..settings
        });
        assert!(off.sun().is_none());
    }
}
