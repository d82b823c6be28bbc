//! Blender's Sky Texture in its Preetham model: the analytic daylight of Preetham, Shirley &
//! Smits (1999), "A Practical Analytic Model for Daylight". Perez et al.'s five-parameter
//! distribution, its parameters linear in the turbidity, gives the luminance Y and the
//! chromaticities x and y of each direction relative to the zenith; the zenith's values are the
//! paper's fits in the sun's zenith angle and the turbidity. Evaluated as Cycles evaluates the
//! node: the zenith luminance scaled by 0.06, directions below the horizon given the horizon's
//! colour, xyY turned into linear Rec. 709 RGB (negative values clamped). There is no sun disc.
//!
//! Directions are in Blender's world frame (Z up), the sun's given as Blender's Sun Direction
//! vector. Units are Cycles': the sky's radiance for a Background strength of 1.

use super::sky::xyz_to_rec709;
use crate::math::Vec3;
use std::f32::consts::{FRAC_PI_2, PI};

/// The zenith angle below which directions are evaluated: a hair above the horizon.
pub(super) const HORIZON_THETA: f32 = FRAC_PI_2 - 0.001;

/// A Preetham sky ready for lookups.
#[derive(Clone, Debug)]
pub struct PreethamSky {
    /// Zenith angle and azimuth (`atan2(x, y)`) of the sun.
    sun_theta: f32,
    sun_phi: f32,
    /// Y, x and y of the zenith, each divided by its distribution's value there.
    zenith: [f32; 3],
    /// Perez et al.'s parameters A–E for Y, x and y.
    perez: [[f32; 5]; 3],
}

/// Zenith angle and azimuth (`atan2(x, y)`, Blender's convention for the sky) of unit `dir`.
pub(super) fn spherical(dir: Vec3) -> (f32, f32) {
    (dir.z.clamp(-1.0, 1.0).acos(), dir.x.atan2(dir.y))
}

/// The angle between the directions of zenith angles and azimuths (`theta_a`, `phi_a`) and
/// (`theta_b`, `phi_b`).
pub(super) fn angle_between(theta_a: f32, phi_a: f32, theta_b: f32, phi_b: f32) -> f32 {
    let cos = theta_a.sin() * theta_b.sin() * (phi_a - phi_b).cos() + theta_a.cos() * theta_b.cos();
    cos.clamp(-1.0, 1.0).acos()
}

/// Perez et al.'s distribution at zenith angle `theta`, angle `gamma` from the sun.
fn perez(p: &[f32; 5], theta: f32, gamma: f32) -> f32 {
    let cos_gamma = gamma.cos();
    (1.0 + p[0] * (p[1] / theta.cos()).exp())
        * (1.0 + p[2] * (p[3] * gamma).exp() + p[4] * cos_gamma * cos_gamma)
}

impl PreethamSky {
    /// The sky for the sun towards `sun_direction` (any length but zero) and `turbidity`.
    pub fn new(sun_direction: Vec3, turbidity: f32) -> PreethamSky {
        let (theta, phi) = spherical(sun_direction.normalize_or(Vec3::Z));
        let t = turbidity;
        let (t2, th, th2, th3) = (t * t, theta, theta * theta, theta * theta * theta);
        let chi = (4.0 / 9.0 - t / 120.0) * (PI - 2.0 * theta);
        let luminance = 0.06 * ((4.0453 * t - 4.9710) * chi.tan() - 0.2155 * t + 2.4192);
        let x = (0.00166 * th3 - 0.00375 * th2 + 0.00209 * th) * t2
            + (-0.02903 * th3 + 0.06377 * th2 - 0.03202 * th + 0.00394) * t
            + (0.11693 * th3 - 0.21196 * th2 + 0.06052 * th + 0.25886);
        let y = (0.00275 * th3 - 0.00610 * th2 + 0.00317 * th) * t2
            + (-0.04214 * th3 + 0.08970 * th2 - 0.04153 * th + 0.00516) * t
            + (0.15346 * th3 - 0.26756 * th2 + 0.06670 * th + 0.26688);
        let linear = |a: [f32; 5], b: [f32; 5]| std::array::from_fn(|i| a[i] * t + b[i]);
        let perez_params = [
            linear(
                [0.1787, -0.3554, -0.0227, 0.1206, -0.0670],
                [-1.4630, 0.4275, 5.3251, -2.5771, 0.3703],
            ),
            linear(
                [-0.0193, -0.0665, -0.0004, -0.0641, -0.0033],
                [-0.2592, 0.0008, 0.2125, -0.8989, 0.0452],
            ),
            linear(
                [-0.0167, -0.0950, -0.0079, -0.0441, -0.0109],
                [-0.2608, 0.0092, 0.2102, -1.6537, 0.0529],
            ),
        ];
        let zenith = [luminance, x, y];
        PreethamSky {
            sun_theta: theta,
            sun_phi: phi,
            zenith: std::array::from_fn(|i| zenith[i] / perez(&perez_params[i], 0.0, theta)),
            perez: perez_params,
        }
    }

    /// Radiance (linear Rec. 709) of the sky along unit `dir`.
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        let (theta, phi) = spherical(dir);
        let gamma = angle_between(theta, phi, self.sun_theta, self.sun_phi);
        let theta = theta.min(HORIZON_THETA);
        let [luminance, x, y] =
            std::array::from_fn(|i| self.zenith[i] * perez(&self.perez[i], theta, gamma));
        if y == 0.0 {
            return xyz_to_rec709(Vec3::new(0.0, luminance, 0.0));
        }
        let z = if luminance != 0.0 {
            (1.0 - x - y) / y * luminance
        } else {
            0.0
        };
        xyz_to_rec709(Vec3::new(x / y * luminance, luminance, z))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The zenith's distribution value is divided out, so the zenith's luminance is the
    /// paper's fit (× Cycles' 0.06): for turbidity 2.2 and the sun 30° above the horizon,
    /// (4.0453 T − 4.9710) tan χ − 0.2155 T + 2.4192 = 3.83 kcd/m².
    #[test]
    fn the_zenith_has_the_fitted_luminance() {
        let sun = Vec3::new(0.0, 60f32.to_radians().sin(), 30f32.to_radians().sin());
        let sky = PreethamSky::new(sun, 2.2);
        let chi = (4.0 / 9.0 - 2.2 / 120.0) * (PI - 2.0 * 60f32.to_radians());
        let expected = 0.06 * ((4.0453 * 2.2 - 4.9710) * chi.tan() - 0.2155 * 2.2 + 2.4192);
        let zenith = sky.radiance(Vec3::Z);
        // Y of linear Rec. 709.
        let luminance = 0.2126 * zenith.x + 0.7152 * zenith.y + 0.0722 * zenith.z;
        assert!(
            (luminance / expected - 1.0).abs() < 2e-3,
            "{luminance} {expected}"
        );
        // Brighter towards the sun than away from it, blue overhead, the ground the horizon's.
        let towards = sky.radiance(Vec3::new(0.0, 0.9, 0.3).normalize());
        let away = sky.radiance(Vec3::new(0.0, -0.9, 0.3).normalize());
        assert!(towards.y > 2.0 * away.y, "{towards} {away}");
        assert!(zenith.z > zenith.x, "{zenith}");
        let horizon = sky.radiance(Vec3::new(1.0, 0.0, 0.0));
        let below = sky.radiance(Vec3::new(1.0, 0.0, -0.05).normalize());
        assert!(
            (below - horizon).length() < 0.05 * horizon.length(),
            "{horizon} {below}"
        );
    }
}
