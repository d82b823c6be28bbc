//! The one place where light units are converted (docs/ARCHITECTURE.md, "Conventions").
//!
//! Blender's glTF exporter, in its default "Standard" lighting mode, writes punctual lights in
//! photometric units with 683 lm/W: point and spot intensity in candela = W/sr × 683, sun
//! illuminance in lux = W/m² × 683. Blender's light power P (watts) relates to intensity by
//! I = P / 4π for point and spot lights alike (the cone does not concentrate power, as in Cycles).

use std::f32::consts::PI;

/// Luminous efficacy Blender's exporter assumes, lm/W.
pub const LUMENS_PER_WATT: f32 = 683.0;

/// glTF point/spot intensity (cd) → radiant intensity (W/sr).
pub fn candela_to_watts_per_sr(cd: f32) -> f32 {
    cd / LUMENS_PER_WATT
}

/// glTF directional illuminance (lx) → irradiance (W/m²).
pub fn lux_to_watts_per_m2(lux: f32) -> f32 {
    lux / LUMENS_PER_WATT
}

/// Blender point/spot power (W) → radiant intensity (W/sr).
pub fn blender_point_power_to_intensity(watts: f32) -> f32 {
    watts / (4.0 * PI)
}

/// Blender area light power (W) on a one-sided emitter of `area` m² → radiance (W/m²/sr),
/// with Blender's "normalize" on (the default): L = P / (π A).
pub fn blender_area_power_to_radiance(watts: f32, area: f32) -> f32 {
    watts / (PI * area)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blender_default_point_light_round_trips() {
        // The default scene's 1000 W point light is exported as 54351.4 cd (measured in Blender 4.5).
        let i = candela_to_watts_per_sr(54351.4);
        assert!((i - blender_point_power_to_intensity(1000.0)).abs() < 1e-3 * i);
    }

    #[test]
    fn sun_and_area_conversions_match_cycles_measurements() {
        // A 3 W/m² sun is exported as 2049 lx.
        assert!((lux_to_watts_per_m2(2049.0) - 3.0).abs() < 1e-5);
        // Cycles: 100 W square area light of 1 m² has radiance 31.831.
        assert!((blender_area_power_to_radiance(100.0, 1.0) - 31.831).abs() < 1e-3);
    }
}
