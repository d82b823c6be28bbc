//! Participating media along a ray: free-flight sampling, emission and transmittance through
//! the media a ray travels in (fog, smoke, fire; Blender's volume shaders).
//!
//! Homogeneous media are integrated exactly: emission in closed form, free flights drawn per
//! colour channel with the channel chosen in proportion to the path's throughput and the
//! draws combined by the one-sample MIS over channels (spectral MIS, as Cycles and pbrt-v4
//! handle chromatic media). Heterogeneous media — coefficients that vary from point to point —
//! are tracked against a grey majorant: tentative collisions at the majorant's rate, each a
//! real scattering with probability σ_s / σ̄ and otherwise a null collision weighted by
//! (σ̄ − σ_t) / (σ̄ − σ_s) (weighted delta tracking in the null-scattering formulation of Miller,
//! Georgiev & Jarosz 2019; Kutz et al. 2017), emission counted at every tentative collision as
//! E / σ̄; shadow rays use ratio tracking (Novák, Selle & Jarosz 2014). Both are unbiased as long
//! as the majorant bounds σ_t; where it does not, null weights are clamped at zero.

use crate::math::Vec3;
use crate::phase::Phase;
use crate::rng::Rng;

/// What a medium is at one point: scattering and absorption coefficients (per unit length, per
/// colour channel), emission (radiance added per unit length, Cycles' volume emission) and
/// the phase function of the scattering.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coefficients {
    pub scattering: Vec3,
    pub absorption: Vec3,
    pub emission: Vec3,
    pub phase: Phase,
}

impl Coefficients {
    /// Empty space.
    pub const VACUUM: Coefficients = Coefficients {
        scattering: Vec3::ZERO,
        absorption: Vec3::ZERO,
        emission: Vec3::ZERO,
        phase: Phase::HenyeyGreenstein(0.0),
    };

    /// The extinction coefficient σ_t = σ_s + σ_a.
    pub fn extinction(&self) -> Vec3 {
        self.scattering + self.absorption
    }

    /// Media that overlap add their coefficients (Cycles sums the volume closures of every
    /// object a point is in); the scattered light leaves by one of their phase functions,
    /// picked in proportion to its scattering (`u` uniform in [0, 1)), which is their mixture
    /// on average.
    pub fn add(&mut self, other: &Coefficients, u: f32) {
        let mine = mean(self.scattering);
        let theirs = mean(other.scattering);
        if theirs > 0.0 && u * (mine + theirs) >= mine {
            self.phase = other.phase;
        }
        self.scattering += other.scattering;
        self.absorption += other.absorption;
        self.emission += other.emission;
    }
}

fn mean(v: Vec3) -> f32 {
    (v.x + v.y + v.z) / 3.0
}

/// The media a ray travels in, summed: what `fly` and `transmittance` read.
pub trait Media {
    /// The coefficients at `p`, their phase function picked by `u` (`Coefficients::add`).
    fn at(&self, p: Vec3, u: f32) -> Coefficients;
    /// The coefficients when they are the same everywhere (every medium homogeneous).
    fn homogeneous(&self) -> Option<Coefficients>;
    /// A grey bound of σ_t's channels over the media (tentative collisions' rate).
    fn majorant(&self) -> f32;
    /// A grey bound of σ_t along the ray `origin + t dir` from `t` on, and the distance
    /// where it stops holding (a majorant grid's block ends); by default `majorant` for the
    /// whole ray.
    fn majorant_along(&self, _origin: Vec3, _dir: Vec3, _t: f32) -> (f32, f32) {
        (self.majorant(), f32::INFINITY)
    }
}

/// Media seen without their scattering: light they scatter counts as absorbed (σ_a + σ_s, no
/// σ_s), so `fly` through them attenuates and adds emission but never scatters. For estimators
/// that add the scattered light themselves (the photon method's volume photon map).
pub struct WithoutScattering<'a, M: Media>(pub &'a M);

impl<M: Media> Media for WithoutScattering<'_, M> {
    fn at(&self, p: Vec3, u: f32) -> Coefficients {
        absorbing(self.0.at(p, u))
    }
    fn homogeneous(&self) -> Option<Coefficients> {
        self.0.homogeneous().map(absorbing)
    }
    fn majorant(&self) -> f32 {
        self.0.majorant()
    }
    fn majorant_along(&self, origin: Vec3, dir: Vec3, t: f32) -> (f32, f32) {
        self.0.majorant_along(origin, dir, t)
    }
}

fn absorbing(c: Coefficients) -> Coefficients {
    Coefficients {
        scattering: Vec3::ZERO,
        absorption: c.absorption + c.scattering,
        ..c
    }
}

/// What a free flight along a segment met.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Flight {
    /// A real scattering at distance `t` along the ray, where the media are `at`.
    Scattered { t: f32, at: Coefficients },
    /// The flight reached the segment's end.
    Passed,
    /// The path's throughput vanished (absorbed).
    Absorbed,
}

/// Above this many tentative collisions a flight or a transmittance ends (a majorant far
/// above the media's extinction only costs time; this bounds it).
const MAX_COLLISIONS: u32 = 100_000;

/// A free flight from `origin` along unit `dir` over `length` through `media`: `beta` (the
/// path's throughput) is reweighted so that the expected result is the radiance transport, and
/// the media's emission along the way, times `beta`, is added to `emitted`.
pub fn fly(
    media: &impl Media,
    origin: Vec3,
    dir: Vec3,
    length: f32,
    beta: &mut Vec3,
    emitted: &mut Vec3,
    rng: &mut Rng,
) -> Flight {
    if let Some(c) = media.homogeneous() {
        return fly_homogeneous(&c, length, beta, emitted, rng);
    }
    let mut t = 0.0;
    for _ in 0..MAX_COLLISIONS {
        let Some((next, majorant)) = tentative_collision(media, origin, dir, t, length, rng) else {
            return Flight::Passed;
        };
        t = next;
        let at = media.at(origin + t * dir, rng.uniform());
        *emitted += *beta * at.emission / majorant;
        let p_scatter = (mean(at.scattering) / majorant).clamp(0.0, 1.0);
        if rng.uniform() < p_scatter {
            *beta *= at.scattering / (majorant * p_scatter);
            return Flight::Scattered { t, at };
        }
        let null = (Vec3::splat(majorant) - at.extinction()).max(Vec3::ZERO);
        *beta *= null / (majorant * (1.0 - p_scatter));
        if *beta == Vec3::ZERO || !beta.is_finite() {
            return Flight::Absorbed;
        }
    }
    Flight::Absorbed
}

/// The next tentative collision after `t` (and before `length`) along the ray, with the
/// majorant there: exponential steps at the rate of each stretch of the piecewise-constant
/// majorant (`Media::majorant_along`), a step that leaves its stretch starting afresh at the
/// stretch's end (the exponential distribution forgets how far it went). `None` past `length`.
fn tentative_collision(
    media: &impl Media,
    origin: Vec3,
    dir: Vec3,
    mut t: f32,
    length: f32,
    rng: &mut Rng,
) -> Option<(f32, f32)> {
    for _ in 0..MAX_COLLISIONS {
        let (majorant, end) = media.majorant_along(origin, dir, t);
        let end = end.min(length);
        if majorant > 0.0 {
            let next = t - (1.0 - rng.uniform()).ln() / majorant;
            if next < end {
                return Some((next, majorant));
            }
        }
        if !(end < length) {
            return None;
        }
        t = end;
    }
    None
}

/// `fly` through homogeneous media `c`: closed-form emission and transmittance, a scattering
/// distance drawn in one channel chosen by the throughput, weighted by the MIS over channels.
fn fly_homogeneous(
    c: &Coefficients,
    length: f32,
    beta: &mut Vec3,
    emitted: &mut Vec3,
    rng: &mut Rng,
) -> Flight {
    let sigma_t = c.extinction();
    if c.emission != Vec3::ZERO {
        // ∫₀ᵈ e^(−σ_t t) E dt per channel (E·d where σ_t is 0).
        let integral = |s: f32| {
            if s * length < 1e-4 {
                length * (1.0 - 0.5 * s * length)
            } else {
                (1.0 - (-s * length).exp()) / s
            }
        };
        let span = Vec3::new(
            integral(sigma_t.x),
            integral(sigma_t.y),
            integral(sigma_t.z),
        );
        *emitted += *beta * c.emission * span;
    }
    if c.scattering == Vec3::ZERO {
        *beta *= (-sigma_t * length).exp();
        return if *beta == Vec3::ZERO {
            Flight::Absorbed
        } else {
            Flight::Passed
        };
    }
    // The channel whose distance is drawn, in proportion to the throughput.
    let weights = beta.abs();
    let total = weights.x + weights.y + weights.z;
    if !(total > 0.0) {
        return Flight::Absorbed;
    }
    let p = weights / total;
    let u = rng.uniform() * total;
    let channel = if u < weights.x {
        0
    } else if u < weights.x + weights.y {
        1
    } else {
        2
    };
    let t = -(1.0 - rng.uniform()).ln() / sigma_t[channel];
    if t < length {
        let transmittance = (-sigma_t * t).exp();
        let pdf = (p * sigma_t * transmittance).element_sum();
        *beta *= transmittance * c.scattering / pdf;
        Flight::Scattered { t, at: *c }
    } else {
        let transmittance = (-sigma_t * length).exp();
        let survive = (p * transmittance).element_sum();
        if !(survive > 0.0) {
            return Flight::Absorbed;
        }
        *beta *= transmittance / survive;
        Flight::Passed
    }
}

/// The fraction of light that crosses `length` from `origin` along unit `dir` through `media`
/// (exact for homogeneous media, ratio tracking otherwise: unbiased, never above one).
pub fn transmittance(
    media: &impl Media,
    origin: Vec3,
    dir: Vec3,
    length: f32,
    rng: &mut Rng,
) -> Vec3 {
    if let Some(c) = media.homogeneous() {
        return (-c.extinction() * length).exp();
    }
    let mut through = Vec3::ONE;
    let mut t = 0.0;
    for _ in 0..MAX_COLLISIONS {
        let Some((next, majorant)) = tentative_collision(media, origin, dir, t, length, rng) else {
            return through;
        };
        t = next;
        let at = media.at(origin + t * dir, 0.0);
        through *= (Vec3::ONE - at.extinction() / majorant).max(Vec3::ZERO);
        // Russian roulette once little is left: unbiased, and it ends long dense tracks.
        let left = through.max_element();
        if left < 0.1 {
            if rng.uniform() >= left / 0.1 {
                return Vec3::ZERO;
            }
            through /= left / 0.1;
        }
    }
    Vec3::ZERO
}

/// The density of light-sampled points along a ray segment (`distance_or_equiangular`): with
/// probability ½ by the media's free-flight density, truncated to the segment, and with
/// probability ½ by equiangular sampling about a point light or a point drawn on a light
/// (Kulla & Fajardo 2012: uniform in the angle the segment subtends from it), which follows the
/// 1/d² of light near the ray. One-sample MIS by the balance heuristic: the pdf is the mixture's.
///
/// The free-flight density is per channel in homogeneous media (the channel chosen by the
/// throughput) and, in heterogeneous ones, that of the piecewise-constant majorant along the
/// ray (`Media::majorant_along`: a majorant grid's blocks), which follows where the medium is
/// dense. A single bound for the whole ray would draw most points near the segment's start
/// where a sparse medium is bounded loosely (overlapping Volume objects add their bounds), and
/// the few points drawn deep in it would carry large weights.
pub struct SegmentSampler<'a> {
    distance: Distance<'a>,
    length: f32,
    /// Equiangular: the projection of the centre on the ray, its distance from the ray and the
    /// angles of the segment's ends.
    equiangular: Option<(f32, f32, f32, f32)>,
}

/// How `SegmentSampler` draws distances by free flight.
enum Distance<'a> {
    /// Per channel: the rate and its probability.
    Channels { rates: Vec3, channel_p: Vec3 },
    /// The majorant of `media` along the ray from `origin` along `dir`, whose integral over
    /// the whole segment is `depth`.
    Majorant {
        media: &'a dyn Media,
        origin: Vec3,
        dir: Vec3,
        depth: f32,
    },
}

impl<'a> SegmentSampler<'a> {
    /// A sampler over [0, `length`] along unit `dir` from `origin` through homogeneous media
    /// of per-channel extinction `rates`, channels weighted by `throughput`, with equiangular
    /// sampling about `centre` when given.
    pub fn new(
        origin: Vec3,
        dir: Vec3,
        length: f32,
        rates: Vec3,
        throughput: Vec3,
        centre: Option<Vec3>,
    ) -> SegmentSampler<'a> {
        let mut weights = throughput.abs();
        // A channel with no rate over an infinite segment has no density to draw from.
        for c in 0..3 {
            if !(rates[c] > 0.0) && !length.is_finite() {
                weights[c] = 0.0;
            }
        }
        let total = weights.element_sum();
        let channel_p = if total > 0.0 {
            weights / total
        } else {
            Vec3::ZERO
        };
        SegmentSampler {
            distance: Distance::Channels { rates, channel_p },
            length,
            equiangular: equiangular_about(origin, dir, length, centre),
        }
    }

    /// A sampler over [0, `length`] along unit `dir` from `origin` through heterogeneous
    /// `media`, drawing distances by their majorant along the ray, with equiangular sampling
    /// about `centre` when given.
    pub fn through_majorant(
        media: &'a dyn Media,
        origin: Vec3,
        dir: Vec3,
        length: f32,
        centre: Option<Vec3>,
    ) -> SegmentSampler<'a> {
        let (depth, _) = majorant_depth(media, origin, dir, length);
        SegmentSampler {
            distance: Distance::Majorant {
                media,
                origin,
                dir,
                depth,
            },
            length,
            equiangular: equiangular_about(origin, dir, length, centre),
        }
    }

    /// The probability that a free flight of optical depth `depth` ends within the segment.
    fn reach(&self, depth: f32) -> f32 {
        if depth.is_finite() {
            1.0 - (-depth).exp()
        } else {
            1.0
        }
    }

    fn has_distance(&self) -> bool {
        match self.distance {
            Distance::Channels { channel_p, .. } => channel_p.element_sum() > 0.0,
            Distance::Majorant { depth, .. } => depth > 0.0,
        }
    }

    /// A distance along the segment and its density; `None` when neither strategy can draw.
    /// `u` uniform in [0, 1)³.
    pub fn sample(&self, u: [f32; 3]) -> Option<(f32, f32)> {
        let use_equiangular = match (self.has_distance(), self.equiangular.is_some()) {
            (false, false) => return None,
            (true, false) => false,
            (false, true) => true,
            (true, true) => u[0] < 0.5,
        };
        let t = if use_equiangular {
            let (delta, h, a, b) = self.equiangular?;
            delta + h * (a + u[1] * (b - a)).tan()
        } else {
            match self.distance {
                Distance::Channels { rates, channel_p } => {
                    let p = channel_p;
                    let c = if u[2] < p.x {
                        0
                    } else if u[2] < p.x + p.y {
                        1
                    } else {
                        2
                    };
                    let s = rates[c];
                    if s > 0.0 {
                        -(1.0 - u[1] * self.reach(s * self.length)).ln() / s
                    } else {
                        u[1] * self.length
                    }
                }
                Distance::Majorant {
                    media,
                    origin,
                    dir,
                    depth,
                } => {
                    let tau = -(1.0 - u[1] * self.reach(depth)).ln();
                    majorant_inverse(media, origin, dir, self.length, tau)?
                }
            }
        };
        let t = t.clamp(0.0, self.length);
        let pdf = self.pdf(t);
        (pdf > 0.0 && pdf.is_finite()).then_some((t, pdf))
    }

    /// The density `sample` draws distance `t` with.
    pub fn pdf(&self, t: f32) -> f32 {
        let distance = match self.distance {
            Distance::Channels { rates, channel_p } => {
                let mut sum = 0.0;
                for c in 0..3 {
                    let (s, p) = (rates[c], channel_p[c]);
                    if p == 0.0 {
                        continue;
                    }
                    sum += p * if s > 0.0 {
                        s * (-s * t).exp() / self.reach(s * self.length)
                    } else {
                        1.0 / self.length
                    };
                }
                sum
            }
            Distance::Majorant {
                media,
                origin,
                dir,
                depth,
            } => {
                let (to_t, rate) = majorant_depth(media, origin, dir, t);
                rate * (-to_t).exp() / self.reach(depth)
            }
        };
        let equiangular = self.equiangular.map_or(0.0, |(delta, h, a, b)| {
            h / ((b - a) * (h * h + (t - delta) * (t - delta)))
        });
        match (self.has_distance(), self.equiangular.is_some()) {
            (true, true) => 0.5 * (distance + equiangular),
            (true, false) => distance,
            (false, true) => equiangular,
            (false, false) => 0.0,
        }
    }
}

/// Equiangular sampling's parameters for the segment [0, `length`] along unit `dir` from
/// `origin` about `centre`: the projection of the centre on the ray, its distance from the
/// ray and the angles of the segment's ends (`None` without a centre or on the ray's line).
fn equiangular_about(
    origin: Vec3,
    dir: Vec3,
    length: f32,
    centre: Option<Vec3>,
) -> Option<(f32, f32, f32, f32)> {
    let c = centre?;
    let delta = (c - origin).dot(dir);
    let h = (c - origin - delta * dir).length();
    if !(h > 1e-6 * (1.0 + delta.abs())) || !h.is_finite() {
        return None;
    }
    let a = (-delta / h).atan();
    let b = if length.is_finite() {
        ((length - delta) / h).atan()
    } else {
        std::f32::consts::FRAC_PI_2
    };
    (b > a).then_some((delta, h, a, b))
}

/// The majorant of `media` integrated along the ray `origin + t dir` from 0 to `t` (infinite
/// when it never falls to zero on an infinite ray), and the majorant at `t`.
fn majorant_depth(media: &dyn Media, origin: Vec3, dir: Vec3, t: f32) -> (f32, f32) {
    let mut depth = 0.0;
    let mut from = 0.0;
    for _ in 0..MAX_COLLISIONS {
        let (rate, end) = media.majorant_along(origin, dir, from);
        if end >= t {
            if rate > 0.0 {
                depth += rate * (t - from);
            }
            return (depth, rate);
        }
        depth += rate * (end - from);
        from = end;
    }
    (depth, 0.0)
}

/// The distance along the ray `origin + t dir`, within `length`, at which the majorant of
/// `media` integrates to `tau`; `None` when it never does.
fn majorant_inverse(
    media: &dyn Media,
    origin: Vec3,
    dir: Vec3,
    length: f32,
    tau: f32,
) -> Option<f32> {
    let mut depth = 0.0;
    let mut from = 0.0;
    for _ in 0..MAX_COLLISIONS {
        let (rate, end) = media.majorant_along(origin, dir, from);
        let end = end.min(length);
        if rate > 0.0 {
            let next = depth + rate * (end - from);
            if tau < next {
                return Some(from + (tau - depth) / rate);
            }
            depth = next;
        }
        if !(end < length) {
            return None;
        }
        from = end;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A slab of density varying along x (heterogeneous) or constant.
    struct Slab {
        base: Coefficients,
        varying: bool,
    }

    impl Media for Slab {
        fn at(&self, p: Vec3, _u: f32) -> Coefficients {
            let mut c = self.base;
            if self.varying {
                let k = 0.5 + 0.5 * (3.0 * p.x).sin();
                c.scattering *= k;
                c.absorption *= k;
                c.emission *= k;
            }
            c
        }
        fn homogeneous(&self) -> Option<Coefficients> {
            (!self.varying).then_some(self.base)
        }
        fn majorant(&self) -> f32 {
            self.base.extinction().max_element()
        }
    }

    fn slab(varying: bool) -> Slab {
        Slab {
            base: Coefficients {
                scattering: Vec3::new(0.6, 0.3, 0.1),
                absorption: Vec3::new(0.2, 0.5, 0.9),
                emission: Vec3::new(0.3, 0.2, 0.1),
                phase: Phase::HenyeyGreenstein(0.0),
            },
            varying,
        }
    }

    /// σ_t integrated along x from 0 to `length` for the slab.
    fn optical_depth(s: &Slab, length: f32) -> Vec3 {
        let sigma = s.base.extinction();
        if s.varying {
            // ∫ 0.5 + 0.5 sin(3x) dx = 0.5 x + (1 − cos 3x) / 6
            sigma * (0.5 * length + (1.0 - (3.0 * length).cos()) / 6.0)
        } else {
            sigma * length
        }
    }

    /// Absorbing media of σ_t 1 for x < 1 and 3 beyond, tracked against a majorant twice
    /// σ_t in each stretch (`majorant_along` stepping at x = 1): transmittance and free
    /// flights (their weight where they pass) both follow e^(−∫σ_t) over the two stretches.
    #[test]
    fn tracking_steps_through_a_piecewise_majorant() {
        struct Steps;
        impl Media for Steps {
            fn at(&self, p: Vec3, _u: f32) -> Coefficients {
                let sigma = if p.x < 1.0 { 1.0 } else { 3.0 };
                Coefficients {
                    absorption: Vec3::splat(sigma),
                    ..Coefficients::VACUUM
                }
            }
            fn homogeneous(&self) -> Option<Coefficients> {
                None
            }
            fn majorant(&self) -> f32 {
                6.0
            }
            fn majorant_along(&self, origin: Vec3, dir: Vec3, t: f32) -> (f32, f32) {
                let x = origin.x + t * dir.x;
                if x < 1.0 {
                    (2.0, (1.0 - origin.x) / dir.x)
                } else {
                    (6.0, f32::INFINITY)
                }
            }
        }
        let want = (-(1.0f32 + 3.0 * 0.5)).exp();
        let mut rng = Rng::new(11);
        let n = 40_000;
        let mut through = 0.0;
        let mut passed = 0.0;
        for _ in 0..n {
            through += transmittance(&Steps, Vec3::ZERO, Vec3::X, 1.5, &mut rng).x;
            let (mut beta, mut emitted) = (Vec3::ONE, Vec3::ZERO);
            if fly(
                &Steps,
                Vec3::ZERO,
                Vec3::X,
                1.5,
                &mut beta,
                &mut emitted,
                &mut rng,
            ) == Flight::Passed
            {
                passed += beta.x;
            }
        }
        let mean = through / n as f32;
        assert!(
            (mean - want).abs() < 0.005,
            "transmittance {mean} vs {want}"
        );
        let flown = passed / n as f32;
        assert!(
            (flown - want).abs() < 0.006,
            "flights' weight {flown} vs {want}"
        );
    }

    /// Segment samples integrate a function of the distance exactly on average, with either
    /// strategy alone or both, over finite and infinite segments.
    #[test]
    fn segment_samples_are_unbiased() {
        let origin = Vec3::ZERO;
        let dir = Vec3::X;
        let centre = Vec3::new(0.7, 0.3, 0.0);
        let f = |t: f32| (-0.8 * t).exp() / (0.09 + (t - 0.7) * (t - 0.7));
        for (length, rates, with_centre) in [
            (2.0, Vec3::new(0.5, 1.0, 3.0), true),
            (2.0, Vec3::new(0.5, 1.0, 3.0), false),
            (2.0, Vec3::ZERO, true),
            (f32::INFINITY, Vec3::new(0.8, 0.8, 0.8), true),
        ] {
            let steps = 400_000;
            let end = if length.is_finite() { length } else { 40.0 };
            let dt = end / steps as f32;
            let want: f64 = (0..steps)
                .map(|i| f((i as f32 + 0.5) * dt) as f64 * dt as f64)
                .sum();
            let sampler = SegmentSampler::new(
                origin,
                dir,
                length,
                rates,
                Vec3::new(1.0, 0.5, 0.25),
                with_centre.then_some(centre),
            );
            let mut rng = Rng::new(17);
            let n = 400_000;
            let mut sum = 0.0f64;
            for _ in 0..n {
                if let Some((t, pdf)) =
                    sampler.sample([rng.uniform(), rng.uniform(), rng.uniform()])
                {
                    sum += (f(t) / pdf) as f64;
                }
            }
            let got = sum / n as f64;
            assert!(
                (got - want).abs() < 0.01 * want,
                "{length} {rates} {with_centre}: {got} vs {want}"
            );
        }
    }

    /// Distances drawn by a piecewise majorant (a dense stretch between two sparse ones, and
    /// nothing past 3 on an infinite ray) integrate a function of the distance exactly on
    /// average, alone and mixed with equiangular sampling, and most points fall where the
    /// majorant is large.
    #[test]
    fn majorant_segment_samples_are_unbiased() {
        struct Stretches;
        impl Media for Stretches {
            fn at(&self, _p: Vec3, _u: f32) -> Coefficients {
                Coefficients::VACUUM
            }
            fn homogeneous(&self) -> Option<Coefficients> {
                None
            }
            fn majorant(&self) -> f32 {
                4.0
            }
            fn majorant_along(&self, origin: Vec3, dir: Vec3, t: f32) -> (f32, f32) {
                let x = origin.x + t * dir.x;
                let (rate, wall) = match x {
                    x if x < 1.0 => (0.3, 1.0),
                    x if x < 2.0 => (4.0, 2.0),
                    x if x < 3.0 => (0.5, 3.0),
                    _ => return (0.0, f32::INFINITY),
                };
                (rate, (wall - origin.x) / dir.x)
            }
        }
        let f = |t: f32| {
            let inside = if t < 3.0 { 1.0 } else { 0.0 };
            inside * (0.5 + (2.0 * t).sin().abs()) / (0.09 + (t - 0.7) * (t - 0.7))
        };
        for (length, with_centre) in [(2.5, false), (2.5, true), (f32::INFINITY, false)] {
            let steps = 300_000;
            let end = length.min(3.0);
            let dt = end / steps as f32;
            let want: f64 = (0..steps)
                .map(|i| f((i as f32 + 0.5) * dt) as f64 * dt as f64)
                .sum();
            let centre = with_centre.then_some(Vec3::new(0.7, 0.3, 0.0));
            let sampler =
                SegmentSampler::through_majorant(&Stretches, Vec3::ZERO, Vec3::X, length, centre);
            let mut rng = Rng::new(23);
            let n = 400_000;
            let (mut sum, mut dense) = (0.0f64, 0);
            for _ in 0..n {
                if let Some((t, pdf)) =
                    sampler.sample([rng.uniform(), rng.uniform(), rng.uniform()])
                {
                    sum += (f(t) / pdf) as f64;
                    dense += (1.0..2.0).contains(&t) as u32;
                }
            }
            let got = sum / n as f64;
            assert!(
                (got - want).abs() < 0.01 * want,
                "{length} {with_centre}: {got} vs {want}"
            );
            if !with_centre {
                assert!(dense > n / 2, "{dense} of {n} in the dense stretch");
            }
        }
    }

    #[test]
    fn transmittance_is_beer_lambert_on_average() {
        for varying in [false, true] {
            let s = slab(varying);
            let length = 1.7;
            let want = (-optical_depth(&s, length)).exp();
            let mut rng = Rng::new(3);
            let n = 200_000;
            let mut sum = Vec3::ZERO;
            for _ in 0..n {
                sum += transmittance(&s, Vec3::ZERO, Vec3::X, length, &mut rng);
            }
            let got = sum / n as f32;
            assert!(
                (got - want).abs().max_element() < 0.004,
                "{varying}: {got} vs {want}"
            );
        }
    }

    /// The expected pass-through weight of `fly` is the transmittance, and the expected
    /// scattered weight is ∫ T σ_s dt; the emission ∫ T E dt.
    #[test]
    fn free_flights_weigh_to_the_transport_equation() {
        for varying in [false, true] {
            let s = slab(varying);
            let length = 1.3;
            let steps = 20_000;
            let dt = length / steps as f32;
            let (mut want_scatter, mut want_emit) = (Vec3::ZERO, Vec3::ZERO);
            for i in 0..steps {
                let x = (i as f32 + 0.5) * dt;
                let c = s.at(Vec3::new(x, 0.0, 0.0), 0.0);
                let t = (-optical_depth(&s, x)).exp();
                want_scatter += t * c.scattering * dt;
                want_emit += t * c.emission * dt;
            }
            let want_pass = (-optical_depth(&s, length)).exp();
            let mut rng = Rng::new(9);
            let n = 400_000;
            let (mut pass, mut scatter, mut emit) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
            for _ in 0..n {
                let mut beta = Vec3::ONE;
                match fly(
                    &s,
                    Vec3::ZERO,
                    Vec3::X,
                    length,
                    &mut beta,
                    &mut emit,
                    &mut rng,
                ) {
                    Flight::Scattered { .. } => scatter += beta,
                    Flight::Passed => pass += beta,
                    Flight::Absorbed => {}
                }
            }
            let (pass, scatter, emit) = (pass / n as f32, scatter / n as f32, emit / n as f32);
            let close = |a: Vec3, b: Vec3| (a - b).abs().max_element() < 0.006;
            assert!(
                close(pass, want_pass),
                "{varying} pass {pass} vs {want_pass}"
            );
            assert!(
                close(scatter, want_scatter),
                "{varying} scatter {scatter} vs {want_scatter}"
            );
            assert!(
                close(emit, want_emit),
                "{varying} emission {emit} vs {want_emit}"
            );
        }
    }
}
