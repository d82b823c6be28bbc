//! Which light a sample goes to. In proportion to the power of each light for scenes of many
//! lights. With at most `MAX_LOCAL_LIGHTS` (and no emitting instance or deforming emitter), half
//! of the samples still go by power and half in proportion to an estimate of the irradiance
//! each light brings to the shading point (`LocalSelection`: its power over the squared
//! distance, the distance clamped by its size; none from a one-sided triangle behind whose
//! plane the point lies; a sun's irradiance), as Cycles' light tree weighs its leaves by
//! energy, orientation and distance (Conty Estevez and Kulla 2018, "Importance Sampling of Many
//! Lights with Adaptive Tree Splitting"). A near lamp then gets samples a far sun of more total
//! power would take; the half by power (a defensive mixture, Hesterberg 1995) keeps every
//! light's share at least half of what it was, which the estimate, blind to the surface's
//! orientation and to shadows, could otherwise starve. Seen from an opaque surface (a `Receiver`
//! with a horizon), a light wholly below the plane of its geometric normal (a triangle's or
//! lamp's bounding sphere, a sun's disc) can light nothing there, so both halves leave it out,
//! as Cycles' light tree leaves out lights outside the shading normal's hemisphere. The
//! densities MIS reads are computed at the vertex the ray left, from the same `Receiver`.

use super::source::Receiver;
use crate::math::Vec3;
use crate::sampling::Distribution1D;

/// Most lights `LocalSelection` weighs one by one at every light sample.
pub(super) const MAX_LOCAL_LIGHTS: usize = 16;

/// Where a light is, for `LocalSelection`.
#[derive(Clone, Copy, Debug)]
pub(super) enum Reach {
    /// The world: the same from every point, never below a horizon.
    Distant,
    /// A sun: the same from every point, its disc within the angle of sine `sin_half` of
    /// `to_sun`.
    Sun { to_sun: Vec3, sin_half: f32 },
    /// Within `radius2.sqrt()` of `centre`; with `front`, a one-sided emitter lighting only
    /// the points in front of the plane through `centre` with that normal.
    Near {
        centre: Vec3,
        radius2: f32,
        front: Option<Vec3>,
    },
}

impl Reach {
    /// A triangle `p`, one-sided along `front` when given.
    pub(super) fn near(p: &[Vec3; 3], front: Option<Vec3>) -> Reach {
        let centre = (p[0] + p[1] + p[2]) / 3.0;
        let radius2 = p
            .iter()
            .map(|&v| (v - centre).length_squared())
            .fold(0.0, f32::max);
        Reach::Near {
            centre,
            radius2,
            front: front.filter(|n| *n != Vec3::ZERO),
        }
    }

    /// A point light, or a lamp of radius `radius`.
    pub(super) fn sphere(centre: Vec3, radius: f32) -> Reach {
        Reach::Near {
            centre,
            radius2: radius * radius,
            front: None,
        }
    }

    /// What the light's irradiance at `p` is proportional to: 1 far away; near, the inverse
    /// squared distance, clamped at the light's size; zero behind a one-sided emitter.
    pub(super) fn falloff(&self, p: Vec3) -> f32 {
        match *self {
            Reach::Distant | Reach::Sun { .. } => 1.0,
            Reach::Near {
                centre,
                radius2,
                front,
            } => {
                let d = p - centre;
                if front.is_some_and(|n| d.dot(n) <= 0.0) {
                    return 0.0;
                }
                1.0 / d.length_squared().max(radius2).max(1e-12)
            }
        }
    }

    /// True when every point of the light lies strictly below the plane through `p` of normal
    /// `n`: no direction towards it leaves the front of that plane.
    pub(super) fn below(&self, p: Vec3, n: Vec3) -> bool {
        match *self {
            Reach::Distant => false,
            Reach::Sun { to_sun, sin_half } => to_sun.dot(n) < -sin_half,
            Reach::Near {
                centre, radius2, ..
            } => (centre - p).dot(n) < -radius2.sqrt(),
        }
    }
}

/// The choice of light for scenes of a few lights: half by power, half by the estimated
/// irradiance at the shading point (module header).
#[derive(Clone, Debug)]
pub(super) struct LocalSelection {
    /// Per light: its power times the factor that makes power × `Reach::falloff` an
    /// irradiance (zero: never picked), and where it is.
    lights: Vec<(f32, Reach)>,
}

impl LocalSelection {
    /// `None` when there are too many lights, or too few to choose between, or no light whose
    /// share changes from point to point.
    pub(super) fn new(power: &[f32], reach: &[Reach], scale: &[f32]) -> Option<LocalSelection> {
        let lights: Vec<(f32, Reach)> = power
            .iter()
            .zip(scale)
            .zip(reach)
            .map(|((&p, &s), &r)| {
                let w = p * s;
                (if w.is_finite() && w > 0.0 { w } else { 0.0 }, r)
            })
            .collect();
        let lit = lights.iter().filter(|(w, _)| *w > 0.0).count();
        let near = lights
            .iter()
            .any(|(w, r)| *w > 0.0 && matches!(r, Reach::Near { .. }));
        (lights.len() <= MAX_LOCAL_LIGHTS && lit > 1 && near).then_some(LocalSelection { lights })
    }

    /// The probability of picking each light from `from`: half in proportion to its estimated
    /// irradiance there, half by power, both among the lights not wholly below `from`'s horizon
    /// (a half left with no light gives its share to the other); all zero when none is left.
    pub(super) fn probabilities(
        &self,
        from: Receiver,
        power: &Distribution1D,
    ) -> [f32; MAX_LOCAL_LIGHTS] {
        let mut by_irradiance = [0.0f32; MAX_LOCAL_LIGHTS];
        let mut by_power = [0.0f32; MAX_LOCAL_LIGHTS];
        let (mut irradiance_total, mut power_total) = (0.0, 0.0);
        for (i, (scale, reach)) in self.lights.iter().enumerate() {
            if from.horizon.is_some_and(|n| reach.below(from.p, n)) {
                continue;
            }
            if *scale > 0.0 {
                by_irradiance[i] = scale * reach.falloff(from.p);
            }
            by_power[i] = power.pmf(i);
            irradiance_total += by_irradiance[i];
            power_total += by_power[i];
        }
        let usable = |total: f32| total > 0.0 && total.is_finite();
        let (irradiance_share, power_share) = match (usable(irradiance_total), usable(power_total))
        {
            (true, true) => (0.5 / irradiance_total, 0.5 / power_total),
            (true, false) => (1.0 / irradiance_total, 0.0),
            (false, true) => (0.0, 1.0 / power_total),
            (false, false) => return [0.0; MAX_LOCAL_LIGHTS],
        };
        std::array::from_fn(|i| by_irradiance[i] * irradiance_share + by_power[i] * power_share)
    }

    /// Pick a light for a sample from `from` with `u`: (index, probability, `u` rescaled to
    /// [0, 1) within the light's share), as `Distribution1D::sample_remapped`; `power` is the
    /// choice by power.
    pub(super) fn sample(
        &self,
        from: Receiver,
        u: f32,
        power: &Distribution1D,
    ) -> Option<(usize, f32, f32)> {
        let probabilities = self.probabilities(from, power);
        let mut below = 0.0;
        let mut last = None;
        for (i, &q) in probabilities[..self.lights.len()].iter().enumerate() {
            if q <= 0.0 {
                continue;
            }
            last = Some((i, below));
            if u < below + q {
                break;
            }
            below += q;
        }
        let (i, below) = last?;
        let remapped = ((u - below) / probabilities[i]).clamp(0.0, 1.0 - f32::EPSILON);
        Some((i, probabilities[i], remapped))
    }

    /// The probability that `sample` from `from` (with the same `power`) picks light `index`.
    pub(super) fn pmf(&self, from: Receiver, index: usize, power: &Distribution1D) -> f32 {
        self.probabilities(from, power)
            .get(index)
            .copied()
            .unwrap_or(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    /// A sun, a point light and a one-sided triangle facing +y, with the powers and scales
    /// `Lights::new` would give them (scene radius 10).
    fn few_lights() -> (LocalSelection, Distribution1D) {
        let triangle = [
            Vec3::new(-1.0, 2.0, 0.0),
            Vec3::new(1.0, 2.0, 0.0),
            Vec3::Y * 2.0 + Vec3::Z,
        ];
        let power = [3.0 * PI * 100.0, 4.0 * PI * 5.0, PI * 40.0 * 1.0];
        let reach = [
            Reach::Sun {
                to_sun: Vec3::Y,
                sin_half: 0.01,
            },
            Reach::sphere(Vec3::new(3.0, 1.0, 0.0), 0.1),
            Reach::near(&triangle, Some(Vec3::Y)),
        ];
        let scale = [1.0 / (PI * 100.0), 1.0 / (4.0 * PI), 1.0 / PI];
        let local = LocalSelection::new(&power, &reach, &scale).expect("a near light");
        (local, Distribution1D::new(&power))
    }

    /// The choice near the shading point is a distribution: its probabilities sum to one, the
    /// share of the unit interval `sample` gives each light is the probability it reports and
    /// `pmf` recomputes, the rescaled number stays in [0, 1), and a light behind a one-sided
    /// emitter keeps only its share by power, and a light wholly below the receiver's horizon
    /// gets nothing.
    #[test]
    fn local_selection_samples_what_its_pmf_says() {
        let (local, power) = few_lights();
        let above = |p: Vec3, n: Vec3| Receiver {
            p,
            horizon: Some(n),
            lit_by: u64::MAX,
        };
        for from in [
            Receiver::at(Vec3::new(0.0, 3.0, 0.2)),
            Receiver::at(Vec3::new(2.5, 1.2, 0.0)),
            Receiver::at(Vec3::new(0.0, 0.0, 0.0)),
            above(Vec3::new(2.5, 1.2, 0.0), -Vec3::Y),
            above(Vec3::new(0.0, 3.5, 0.2), Vec3::X),
        ] {
            let p = from.p;
            let sum: f32 = (0..3).map(|i| local.pmf(from, i, &power)).sum();
            assert!((sum - 1.0).abs() < 1e-5, "sum {sum} at {p:?}");
            let n = 200_000;
            let mut count = [0usize; 3];
            for k in 0..n {
                let u = (k as f32 + 0.5) / n as f32;
                let (i, pmf, remapped) = local.sample(from, u, &power).expect("a light");
                assert!((pmf - local.pmf(from, i, &power)).abs() < 1e-6);
                assert!((0.0..1.0).contains(&remapped), "remapped {remapped}");
                count[i] += 1;
            }
            for (i, &c) in count.iter().enumerate() {
                let expected = local.pmf(from, i, &power);
                assert!(
                    (c as f32 / n as f32 - expected).abs() < 1e-3,
                    "light {i} at {p:?}: drawn {} expected {expected}",
                    c as f32 / n as f32
                );
            }
        }
        // Below the triangle (y < 2, facing +y): only its half by power.
        let below = Vec3::new(0.0, 0.0, 0.0);
        assert!((local.pmf(Receiver::at(below), 2, &power) - 0.5 * power.pmf(2)).abs() < 1e-6);
        // Next to the point light, it takes most of the local half.
        let near = Vec3::new(2.9, 1.0, 0.0);
        assert!(local.pmf(Receiver::at(near), 1, &power) > 0.5 * power.pmf(1) + 0.45);
        // Under a surface facing away from the sun, the sun is never picked; above the
        // triangle and the point light, facing up, only the sun is left.
        assert_eq!(local.pmf(above(near, -Vec3::Y), 0, &power), 0.0);
        let over = above(Vec3::new(0.0, 3.5, 0.2), Vec3::Y);
        assert_eq!(local.pmf(over, 0, &power), 1.0);
        assert_eq!(local.sample(over, 0.99, &power).map(|s| s.0), Some(0));
    }
}
