//! Blender 5's Sky Texture in its Multiple Scattering model (the node's default from Blender
//! 5.0): Fernando García Liñán's spectral sky (his master's thesis, 2022: four wavelength samples
//! and an analytic fit of multiple scattering; his article on the four-sample method, 2024),
//! built on Hillaire's atmosphere (S. Hillaire, 2016, "Physically Based Sky, Atmosphere and
//! Cloud Rendering in Frostbite"). Air (Rayleigh), aerosols (Henyey–Greenstein, g = 0.8) and
//! ozone over a spherical Earth 6371 km in radius with a 100 km atmosphere, sampled at four
//! wavelengths (630, 560, 490 and 430 nm) and turned into CIE XYZ by a fitted 4 × 3 matrix.
//! Light scattered once towards the viewer is integrated along the view ray (64 segments, each
//! integrated analytically over its own extinction, Hillaire's energy-conserving step); the
//! light scattered more than once is an analytic fit: the ground's (albedo 0.3) light scattered
//! a second time plus a term of the sun's cosine at each point.
//!
//! It is evaluated the way Cycles evaluates it, so that a Blender 5 sky lights a scene alike in
//! both: the transmittance towards the sun is tabulated (256 sun cosines × 64 heights), the sky
//! is tabulated over the whole sphere (512 azimuths × 256 rows, the rows at the square root of
//! |elevation| so more of them lie near the horizon; below the horizon the view ray stops at the
//! ground) and looked up bilinearly; the sun disc is apart (`sun`), coloured by the
//! transmittance from the viewer to it, and shown down to the horizon's dip at the viewer's
//! altitude.
//!
//! Directions are in Blender's world frame (Z up). Units are Cycles': the sky's radiance for a
//! Background strength of 1.

use crate::math::{Vec3, Vec4};
use crate::scene::sky::{
    angle_between, bilinear, disc_light, limb_darkening, sun_position, sun_towards, xyz_to_rec709,
    NishitaSettings, SunDisc,
};
use rayon::prelude::*;
use std::f32::consts::{FRAC_1_PI, FRAC_PI_2, PI, TAU};

// The atmosphere (kilometres).
const EARTH_RADIUS: f32 = 6371.0;
const ATMOSPHERE_THICKNESS: f32 = 100.0;
const ATMOSPHERE_RADIUS: f32 = EARTH_RADIUS + ATMOSPHERE_THICKNESS;
const GROUND_ALBEDO: f32 = 0.3;
/// Anisotropy of the aerosols' phase function.
const AEROSOL_G: f32 = 0.8;

// Spectral data at 630, 560, 490 and 430 nm.
/// Solar irradiance at the top of the atmosphere.
const SUN_IRRADIANCE: Vec4 = Vec4::new(1.679, 1.828, 1.986, 1.307);
/// Rayleigh scattering coefficient of air at sea level (1/km).
const AIR_SCATTERING: Vec4 = Vec4::new(6.605e-3, 1.067e-2, 1.842e-2, 3.156e-2);
/// Ozone absorption cross-section (cm²) and the mean column (Dobson units).
const OZONE_CROSS_SECTION: Vec4 = Vec4::new(3.472e-25, 3.914e-25, 1.349e-25, 11.03e-27);
const OZONE_DOBSON: f32 = 334.5;
/// Aerosol absorption and scattering cross-sections, their number density at sea level, the
/// background density that does not fall off with height and the scale height (km).
const AEROSOL_ABSORPTION: Vec4 = Vec4::new(2.8722e-24, 4.6168e-24, 7.9706e-24, 1.3578e-23);
const AEROSOL_SCATTERING: Vec4 = Vec4::new(1.5908e-22, 1.7711e-22, 2.0942e-22, 2.4033e-22);
const AEROSOL_DENSITY: f32 = 1.3681e20;
const AEROSOL_BACKGROUND: f32 = 2e6;
const AEROSOL_SCALE_HEIGHT: f32 = 0.73;
/// Rows of the 4 × 3 matrix from the four samples to CIE XYZ.
const SPECTRAL_TO_XYZ: [[f32; 3]; 4] = [
    [53.386_917, 22.981_337, 0.0],
    [43.904_846, 71.347_8, 0.102_506_87],
    [1.613_727_8, 18.422_96, 31.742_92],
    [20.762_669, 2.361_421_4, 110.480_1],
];
/// The fit of light scattered more than twice: its colour (× 0.02) by wavelength.
const MULTIPLE_SCATTERING_COLOUR: Vec4 = Vec4::new(0.217, 0.347, 0.594, 1.0);

/// Segments of a ray to the sun and of a view ray.
const TRANSMITTANCE_STEPS: usize = 64;
const VIEW_STEPS: usize = 64;
/// The transmittance table: sun cosines from −1 to 1 by heights from the ground to the top.
const TRANSMITTANCE_WIDTH: usize = 256;
const TRANSMITTANCE_HEIGHT: usize = 64;
/// The sky table: azimuths by rows from straight down to straight up.
const TABLE_WIDTH: usize = 512;
const TABLE_HEIGHT: usize = 256;

/// Scattering and extinction coefficients (1/km) at one height.
struct Coefficients {
    air_scattering: Vec4,
    aerosol_scattering: Vec4,
    extinction: Vec4,
}

/// The atmosphere of one set of densities (the node's air, aerosol and ozone factors).
#[derive(Clone, Copy)]
struct Atmosphere {
    air: f32,
    aerosol: f32,
    ozone: f32,
}

impl Atmosphere {
    /// Coefficients at `height` km above the ground: air falling off as a stretched exponential,
    /// aerosols exponentially over a constant background, ozone in a log-normal layer about
    /// 25 km up.
    fn at(&self, height: f32) -> Coefficients {
        let air_scattering =
            AIR_SCATTERING * ((-0.077_719_71 * height.powf(1.163_642_4)).exp() * self.air);
        let log_h = height.max(1e-4).ln();
        let ozone_density = 3.785_474e20 * (-(log_h - 3.22261).powi(2) * 5.555_555_5 - log_h).exp();
        let ozone_absorption = OZONE_CROSS_SECTION * (OZONE_DOBSON * ozone_density * self.ozone);
        let aerosols = AEROSOL_DENSITY
            * ((-height / AEROSOL_SCALE_HEIGHT).exp() + AEROSOL_BACKGROUND / AEROSOL_DENSITY)
            * self.aerosol;
        let aerosol_scattering = AEROSOL_SCATTERING * aerosols;
        Coefficients {
            air_scattering,
            aerosol_scattering,
            extinction: air_scattering
                + aerosol_scattering
                + ozone_absorption
                + AEROSOL_ABSORPTION * aerosols,
        }
    }

    /// Transmittance from `height_fraction` of the way up the atmosphere to its top, towards a
    /// sun whose zenith angle has cosine `cos_sun` (a ray that meets the Earth is marched
    /// through it at ground density, as Cycles does).
    fn transmittance(&self, cos_sun: f32, height_fraction: f32) -> Vec4 {
        let origin = Vec3::new(
            0.0,
            0.0,
            EARTH_RADIUS + ATMOSPHERE_THICKNESS * height_fraction,
        );
        let length = sphere_exit(origin, to_sun(cos_sun), ATMOSPHERE_RADIUS).max(0.0);
        let step = length / TRANSMITTANCE_STEPS as f32;
        let mut depth = Vec4::ZERO;
        for i in 0..TRANSMITTANCE_STEPS {
            let p = origin + to_sun(cos_sun) * (step * (i as f32 + 0.5));
            depth += self.at(height_above_ground(p)).extinction * step;
        }
        (-depth).exp()
    }
}

/// The sun's direction in the tables' frame (azimuth π) for the cosine of its zenith angle.
fn to_sun(cos_zenith: f32) -> Vec3 {
    Vec3::new(
        -(1.0 - cos_zenith * cos_zenith).max(0.0).sqrt(),
        0.0,
        cos_zenith,
    )
}

fn height_above_ground(p: Vec3) -> f32 {
    (p.length() - EARTH_RADIUS).max(0.0)
}

/// Distance along unit `dir` from `origin` to the sphere of `radius` about the Earth's centre:
/// the far crossing from inside, the near one from outside, negative when it is missed.
fn sphere_exit(origin: Vec3, dir: Vec3, radius: f32) -> f32 {
    let b = origin.dot(dir);
    let c = origin.length_squared() - radius * radius;
    if c > 0.0 && b > 0.0 {
        return -1.0;
    }
    let d = b * b - c;
    if d < 0.0 {
        -1.0
    } else if d >= b * b {
        -b + d.sqrt()
    } else {
        -b - d.sqrt()
    }
}

fn air_phase(cos_theta: f32) -> f32 {
    3.0 / (16.0 * PI) * (1.0 + cos_theta * cos_theta)
}

/// Henyey–Greenstein phase of the aerosols, `cos_theta` between the sunlight's direction of
/// travel reversed and the view ray's.
fn aerosol_phase(cos_theta: f32) -> f32 {
    let g2 = AEROSOL_G * AEROSOL_G;
    let den = 1.0 + g2 + 2.0 * AEROSOL_G * cos_theta;
    (1.0 - g2) / (4.0 * PI * den * den.sqrt())
}

fn spectral_to_xyz(l: Vec4) -> Vec3 {
    (0..4).fold(Vec3::ZERO, |xyz, i| {
        xyz + Vec3::from(SPECTRAL_TO_XYZ[i]) * l[i]
    })
}

/// The light scattered more than once that a point sends per unit scattering coefficient (the
/// sun's irradiance apart), at `distance` km from the Earth's centre and `height_fraction` up
/// the atmosphere, the sun at zenith cosine `cos_sun` there: the ground's reflected sunlight
/// scattered isotropically, plus García Liñán's fit of the rest. `transmittance(cos, h)` is the
/// transmittance to the top of the atmosphere.
fn multiple_scattering(
    transmittance: impl Fn(f32, f32) -> Vec4,
    cos_sun: f32,
    height_fraction: f32,
    distance: f32,
) -> Vec4 {
    let ground_solid_angle =
        TAU * (1.0 - (1.0 - (EARTH_RADIUS / distance).powi(2)).max(0.0).sqrt());
    // Ground to point = ground to space over point to space, straight up.
    let ground_to_point = transmittance(1.0, 0.0) / transmittance(1.0, height_fraction);
    let ground = transmittance(cos_sun, 0.0)
        * ground_to_point
        * (ground_solid_angle * GROUND_ALBEDO * FRAC_1_PI * cos_sun / (4.0 * PI));
    let rest = MULTIPLE_SCATTERING_COLOUR * (0.02 / (1.0 + 5.0 * (-17.92 * cos_sun).exp()));
    ground + rest
}

/// The atmosphere with its transmittance table.
struct Tabulated {
    atmosphere: Atmosphere,
    transmittance: Vec<Vec4>,
}

impl Tabulated {
    fn new(atmosphere: Atmosphere) -> Tabulated {
        let mut transmittance = vec![Vec4::ZERO; TRANSMITTANCE_WIDTH * TRANSMITTANCE_HEIGHT];
        transmittance
            .par_chunks_mut(TRANSMITTANCE_WIDTH)
            .enumerate()
            .for_each(|(y, row)| {
                let h = y as f32 / (TRANSMITTANCE_HEIGHT - 1) as f32;
                for (x, t) in row.iter_mut().enumerate() {
                    let cos_sun = 2.0 * x as f32 / (TRANSMITTANCE_WIDTH - 1) as f32 - 1.0;
                    *t = atmosphere.transmittance(cos_sun, h);
                }
            });
        Tabulated {
            atmosphere,
            transmittance,
        }
    }

    /// Bilinear lookup, the table's first and last entries on its corners.
    fn transmittance(&self, cos_sun: f32, height_fraction: f32) -> Vec4 {
        let axis = |t: f32, size: usize| {
            let f = t.clamp(0.0, 1.0) * (size - 1) as f32;
            let i = f as usize;
            (i, (i + 1).min(size - 1), f - i as f32)
        };
        let (x0, x1, fx) = axis(0.5 * cos_sun + 0.5, TRANSMITTANCE_WIDTH);
        let (y0, y1, fy) = axis(height_fraction, TRANSMITTANCE_HEIGHT);
        let at = |x: usize, y: usize| self.transmittance[y * TRANSMITTANCE_WIDTH + x];
        let row = |y: usize| at(x0, y).lerp(at(x1, y), fx);
        row(y0).lerp(row(y1), fy)
    }

    /// Light scattered towards `origin` along the view ray `dir` over its first `length` km in
    /// `steps` segments, the sun towards `sun` (four wavelengths).
    fn inscattering(&self, sun: Vec3, origin: Vec3, dir: Vec3, length: f32, steps: usize) -> Vec4 {
        let cos_theta = -dir.dot(sun);
        let (phase_air, phase_aerosol) = (air_phase(cos_theta), aerosol_phase(cos_theta));
        let step = length / steps as f32;
        let mut radiance = Vec4::ZERO;
        let mut transmittance = Vec4::ONE;
        for i in 0..steps {
            let p = origin + dir * (step * (i as f32 + 0.5));
            let distance = p.length();
            let height = (distance - EARTH_RADIUS).max(0.0);
            let fraction = height / ATMOSPHERE_THICKNESS;
            let cos_sun = (p / distance).dot(sun);
            let c = self.atmosphere.at(height);
            let to_sun = self.transmittance(cos_sun, fraction);
            let ms =
                multiple_scattering(|u, h| self.transmittance(u, h), cos_sun, fraction, distance);
            let source = SUN_IRRADIANCE
                * (c.air_scattering * (to_sun * phase_air + ms)
                    + c.aerosol_scattering * (to_sun * phase_aerosol + ms));
            // The source integrated over the segment's own extinction.
            let step_transmittance = (-c.extinction * step).exp();
            radiance += transmittance * (source - source * step_transmittance)
                / c.extinction.max(Vec4::splat(1e-7));
            transmittance *= step_transmittance;
        }
        radiance
    }
}

/// Where a view ray from `origin` along `dir` stops: the ground or the top of the atmosphere.
fn view_length(origin: Vec3, dir: Vec3) -> f32 {
    let ground = sphere_exit(origin, dir, EARTH_RADIUS);
    if ground < 0.0 {
        sphere_exit(origin, dir, ATMOSPHERE_RADIUS)
    } else {
        ground
    }
}

/// The elevation of the sky table's row coordinate `v` ∈ [0, 1].
fn row_elevation(v: f32) -> f32 {
    let l = 2.0 * v - 1.0;
    l * l.abs() * FRAC_PI_2
}

/// A Multiple Scattering sky ready for lookups.
#[derive(Clone, Debug)]
pub struct MultipleScatteringSky {
    /// CIE XYZ radiance, `TABLE_WIDTH` × `TABLE_HEIGHT`, row 0 looking straight down.
    table: Vec<Vec3>,
    sun_elevation: f32,
    /// The rotation as Cycles' kernel reads it: 2π − the node's rotation.
    sun_rotation: f32,
    sun_size: f32,
    sun_intensity: f32,
    sun_disc: bool,
    /// XYZ radiance of the sun disc at its lowest and highest point.
    sun_bottom: Vec3,
    sun_top: Vec3,
    /// The lowest elevation at which the sun is seen: the horizon's dip at the viewer's
    /// altitude (negative).
    horizon: f32,
}

impl MultipleScatteringSky {
    /// Tabulate the sky for `settings` (Blender's Sky Texture settings; `dust` is the aerosol
    /// density): 256 × 256 view rays (the other half of the table mirrors them) of 64 steps.
    pub fn new(settings: &NishitaSettings) -> MultipleScatteringSky {
        let (elevation, rotation) = sun_position(settings);
        let atmosphere = Atmosphere {
            air: settings.air,
            aerosol: settings.dust,
            ozone: settings.ozone,
        };
        // Within a metre of the ground and above 100 km the model misbehaves.
        let altitude = settings.altitude.clamp(1.0, 99_999.0) / 1000.0;
        let tabulated = Tabulated::new(atmosphere);
        let origin = Vec3::new(0.0, 0.0, EARTH_RADIUS + altitude);
        let sun = to_sun(elevation.sin());
        let mut table = vec![Vec3::ZERO; TABLE_WIDTH * TABLE_HEIGHT];
        table
            .par_chunks_mut(TABLE_WIDTH)
            .enumerate()
            .for_each(|(y, row)| {
                let e = row_elevation((y as f32 + 0.5) / TABLE_HEIGHT as f32);
                // The sky is symmetric about the sun's azimuth: compute half, mirror the rest.
                for x in 0..TABLE_WIDTH / 2 {
                    let azimuth = TAU * (x as f32 + 0.5) / TABLE_WIDTH as f32;
                    let dir = Vec3::new(e.cos() * azimuth.cos(), e.cos() * azimuth.sin(), e.sin());
                    let length = view_length(origin, dir);
                    let l = tabulated.inscattering(sun, origin, dir, length, VIEW_STEPS);
                    let xyz = spectral_to_xyz(l);
                    row[x] = xyz;
                    row[TABLE_WIDTH - 1 - x] = xyz;
                }
            });

        let half = 0.5 * settings.sun_size;
        let solid_angle = TAU * (1.0 - half.cos());
        let fraction = altitude / ATMOSPHERE_THICKNESS;
        let sun_at = |e: f32| {
            spectral_to_xyz(SUN_IRRADIANCE * atmosphere.transmittance(e.sin(), fraction))
                / solid_angle
        };
        let unclamped = settings.altitude.max(0.0) / 1000.0;
        MultipleScatteringSky {
            table,
            sun_elevation: elevation,
            sun_rotation: rotation,
            sun_size: settings.sun_size,
            sun_intensity: settings.sun_intensity,
            sun_disc: settings.sun_disc,
            sun_bottom: sun_at(elevation - half),
            sun_top: sun_at(elevation + half),
            horizon: -(FRAC_PI_2 - (EARTH_RADIUS / (EARTH_RADIUS + unclamped)).asin()),
        }
    }

    /// The table's coordinates of unit `dir`.
    fn table_coordinates(&self, dir: Vec3) -> (f32, f32) {
        let u = (-dir.y.atan2(dir.x) - FRAC_PI_2 + self.sun_rotation) / TAU;
        let elevation = FRAC_PI_2 - dir.z.clamp(-1.0, 1.0).acos();
        let v = 0.5 + 0.5 * (elevation.abs() / FRAC_PI_2).sqrt().copysign(elevation);
        (u - u.floor(), v)
    }

    /// Radiance of the sky along unit `dir`, without the sun disc, over the whole sphere.
    pub fn sky_radiance(&self, dir: Vec3) -> Vec3 {
        let (u, v) = self.table_coordinates(dir);
        xyz_to_rec709(bilinear(&self.table, TABLE_WIDTH, TABLE_HEIGHT, u, v))
    }

    /// Unit direction towards the centre of the sun.
    pub fn sun_direction(&self) -> Vec3 {
        sun_towards(self.sun_elevation, self.sun_rotation)
    }

    /// Radiance of the sun disc along unit `dir` (zero outside it and below the horizon's dip):
    /// interpolated between its bottom and top colours by elevation, darkened towards the limb.
    pub fn sun_radiance(&self, dir: Vec3) -> Vec3 {
        let half = 0.5 * self.sun_size;
        let gamma = angle_between(dir, self.sun_direction());
        let elevation = FRAC_PI_2 - dir.z.clamp(-1.0, 1.0).acos();
        if !self.sun_disc || gamma >= half || elevation <= self.horizon {
            return Vec3::ZERO;
        }
        let t = (elevation - self.sun_elevation) / self.sun_size + 0.5;
        let xyz = self.sun_bottom.lerp(self.sun_top, t) * self.sun_intensity;
        xyz_to_rec709(xyz) * limb_darkening(gamma, half)
    }

    /// The sun disc as a light (`None` without a disc or when none of it is seen).
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

    /// Distance from `p` (inside the sphere of `radius`) along unit `dir` to the sphere.
    fn to_sphere(p: Vec3, dir: Vec3, radius: f32) -> f32 {
        let (p, dir) = (p.as_dvec3(), dir.as_dvec3());
        let b = p.dot(dir);
        (-b + (b * b - p.length_squared() + f64::from(radius).powi(2)).sqrt()) as f32
    }

    /// exp(−∫ extinction) from `p` along `dir` to the top of the atmosphere: a midpoint sum of
    /// `n` segments in f64 (below the ground the air is taken at ground density, as the model
    /// does).
    fn transmittance_to_space(atmosphere: &Atmosphere, p: Vec3, dir: Vec3, n: usize) -> Vec4 {
        let length = to_sphere(p, dir, ATMOSPHERE_RADIUS) as f64;
        let step = length / n as f64;
        let mut depth = [0f64; 4];
        for i in 0..n {
            let q = p + dir * (step * (i as f64 + 0.5)) as f32;
            let e = atmosphere.at(height_above_ground(q)).extinction;
            for (d, k) in depth.iter_mut().zip(e.to_array()) {
                *d += f64::from(k) * step;
            }
        }
        Vec4::from_array(depth.map(|d| (-d).exp() as f32))
    }

    /// The sky's XYZ radiance along `dir` (tables' frame) by brute force: the view ray to the
    /// ground or the top of the atmosphere in 600 plain midpoint segments, each point's
    /// transmittance to the sun (and the multiple-scattering term's transmittances) integrated
    /// along its own ray in 200 segments, no tables.
    fn brute_force_xyz(atmosphere: &Atmosphere, sun: Vec3, altitude: f32, dir: Vec3) -> Vec3 {
        let origin = Vec3::new(0.0, 0.0, EARTH_RADIUS + altitude);
        // The ground, when the ray meets it, else the top of the atmosphere.
        let b = origin.as_dvec3().dot(dir.as_dvec3());
        let c = origin.as_dvec3().length_squared() - f64::from(EARTH_RADIUS).powi(2);
        let length = if b < 0.0 && b * b >= c {
            (-b - (b * b - c).sqrt()) as f32
        } else {
            to_sphere(origin, dir, ATMOSPHERE_RADIUS)
        };
        const N: usize = 600;
        let step = f64::from(length) / N as f64;
        let cos_theta = -dir.dot(sun);
        let mut radiance = [0f64; 4];
        let mut depth = Vec4::ZERO;
        for i in 0..N {
            let p = origin + dir * (step * (i as f64 + 0.5)) as f32;
            let distance = p.length();
            let zenith = p / distance;
            let height = height_above_ground(p);
            let c = atmosphere.at(height);
            let view = (-(depth + c.extinction * (0.5 * step) as f32)).exp();
            depth += c.extinction * step as f32;
            let to_sun = transmittance_to_space(atmosphere, p, sun, 200);
            // The model's transmittance from a height fraction along a zenith cosine, here
            // integrated directly.
            let up_from = |cos: f32, h: f32| {
                let start = Vec3::new(0.0, 0.0, EARTH_RADIUS + ATMOSPHERE_THICKNESS * h);
                transmittance_to_space(atmosphere, start, to_sun_dir(cos), 200)
            };
            let ms = multiple_scattering(
                up_from,
                zenith.dot(sun),
                height / ATMOSPHERE_THICKNESS,
                distance,
            );
            let source = SUN_IRRADIANCE
                * (c.air_scattering * (to_sun * air_phase(cos_theta) + ms)
                    + c.aerosol_scattering * (to_sun * aerosol_phase(cos_theta) + ms));
            for (r, s) in radiance.iter_mut().zip((view * source).to_array()) {
                *r += f64::from(s) * step;
            }
        }
        spectral_to_xyz(Vec4::from_array(radiance.map(|r| r as f32)))
    }

    fn to_sun_dir(cos_zenith: f32) -> Vec3 {
        to_sun(cos_zenith)
    }

    /// The tabulated sky (transmittance table, 64 analytic steps a view ray, as Cycles) and the
    /// same with 4096 steps against the model's equations integrated by brute force, at texel centres looking up, towards and
    /// away from the sun, along the horizon and down at the ground, for the sun at 12° and 50°;
    /// and the lookup of a world direction lands on its texel.
    #[test]
    fn table_matches_brute_force_integration() {
        let atmosphere = Atmosphere {
            air: 1.0,
            aerosol: 1.0,
            ozone: 1.0,
        };
        for elevation in [12f32, 50.0] {
            let settings = NishitaSettings {
                sun_elevation: elevation.to_radians(),
                altitude: 100.0,
                ..NishitaSettings::default()
            };
            let sky = MultipleScatteringSky::new(&settings);
            let tabulated = Tabulated::new(atmosphere);
            let sun = to_sun(settings.sun_elevation.sin());
            // (column, row): the sun is at column 256 (azimuth π), row 128 is the horizon.
            for (x, y) in [
                (255, 250),
                (250, 170),
                (10, 170),
                (130, 140),
                (255, 129),
                (200, 60),
            ] {
                let (u, v) = (
                    (x as f32 + 0.5) / TABLE_WIDTH as f32,
                    (y as f32 + 0.5) / TABLE_HEIGHT as f32,
                );
                let (azimuth, e) = (TAU * u, row_elevation(v));
                let dir = Vec3::new(e.cos() * azimuth.cos(), e.cos() * azimuth.sin(), e.sin());
                let expected = brute_force_xyz(&atmosphere, sun, 0.1, dir);
                let got = sky.table[y * TABLE_WIDTH + x];
                let relative = |a: Vec3| ((a - expected).abs() / expected).max_element();
                // Cycles' 64 segments a view ray, each with its middle's coefficients, miss
                // some of the aerosols' light near the ground (9 % towards a low sun).
                assert!(
                    relative(got) < 0.1,
                    "sun {elevation}°, texel ({x}, {y}): table {got}, brute force {expected}"
                );
                // With 4096 segments the tabulated model meets the brute force, but for the
                // transmittance table's linear steps between rows 1.6 km apart (1.3 % on a
                // short ray to the ground).
                let origin = Vec3::new(0.0, 0.0, EARTH_RADIUS + 0.1);
                let length = view_length(origin, dir);
                let fine = spectral_to_xyz(tabulated.inscattering(sun, origin, dir, length, 4096));
                assert!(
                    relative(fine) < 0.02,
                    "sun {elevation}°, texel ({x}, {y}): 4096 steps {fine}, brute force {expected}"
                );
                // The world direction of the texel's centre (rotation 0) reads the texel.
                let phi = sky.sun_rotation - FRAC_PI_2 - TAU * u;
                let world = Vec3::new(e.cos() * phi.cos(), e.cos() * phi.sin(), e.sin());
                let looked_up = sky.sky_radiance(world);
                let texel = xyz_to_rec709(got);
                assert!(
                    (looked_up - texel).abs().max_element() <= 1e-3 * texel.max_element(),
                    "{looked_up} {texel}"
                );
            }
        }
    }

    /// The sun disc's colours are the sunlight through the air to the viewer over the disc's
    /// solid angle; the disc is seen down to the horizon's dip (0.32° at 100 m), not below; it
    /// faces the sun's azimuth as in Blender (rotation 0: towards +Y).
    #[test]
    fn sun_disc_is_the_transmitted_sunlight() {
        let atmosphere = Atmosphere {
            air: 1.0,
            aerosol: 1.0,
            ozone: 1.0,
        };
        let settings = NishitaSettings {
            sun_elevation: 30f32.to_radians(),
            altitude: 100.0,
            ..NishitaSettings::default()
        };
        let sky = MultipleScatteringSky::new(&settings);
        let half = 0.5 * settings.sun_size;
        let solid_angle = TAU * (1.0 - half.cos());
        let origin = Vec3::new(0.0, 0.0, EARTH_RADIUS + 0.1);
        let top = settings.sun_elevation + half;
        let through = transmittance_to_space(&atmosphere, origin, to_sun(top.sin()), 2000);
        let expected = spectral_to_xyz(SUN_IRRADIANCE * through) / solid_angle;
        let error = ((sky.sun_top - expected).abs() / expected).max_element();
        // The sky's 64 segments towards the sun against 2000.
        assert!(error < 0.01, "{} {expected}", sky.sun_top);
        let direction = sky.sun_direction();
        assert!(direction.y > 0.8 && direction.x.abs() < 1e-5, "{direction}");
        let sun = sky.sun().expect("a sun");
        assert!(sun.irradiance.min_element() > 0.0);
        let at = |degrees: f32| {
            MultipleScatteringSky::new(&NishitaSettings {
                sun_elevation: degrees.to_radians(),
                ..settings
            })
            .sun()
        };
        assert!(at(-0.1).is_some() && at(-1.0).is_none());
        // The sky below the horizon is the air between the viewer and the ground, not black.
        assert!(sky.sky_radiance(-Vec3::Z).min_element() > 0.0);
    }
}
