//! Small geometric helpers on top of glam: orthonormal frames, colour luminance, reflection and
//! refraction. Colours are linear Rec.709 RGB stored in `Vec3`.

pub use glam::{Affine3A, Mat3, Mat4, Quat, Vec2, Vec3, Vec3A, Vec3Swizzles, Vec4};

/// An orthonormal basis. Shading happens in the local frame where the normal is +Z, so
/// `cos θ = w.z`.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// A frame around the unit vector `n` (Duff et al. 2017, "Building an Orthonormal Basis, Revisited").
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    /// A frame around `n` whose first axis follows `tangent` (projected and normalised); falls back
    /// to `from_normal` when the tangent is degenerate or parallel to `n`.
    pub fn from_normal_tangent(n: Vec3, tangent: Vec3) -> Self {
        let s = tangent - n * n.dot(tangent);
        let len2 = s.length_squared();
        if len2 <= 1e-12 || !len2.is_finite() {
            return Self::from_normal(n);
        }
        let s = s / len2.sqrt();
        Frame {
            s,
            t: n.cross(s),
            n,
        }
    }

    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// `t` turned by `angle` (radians, right-handed) around the unit vector `n`, after Cycles'
/// `rotate_around_axis`.
pub fn rotate_around(t: Vec3, n: Vec3, angle: f32) -> Vec3 {
    let (s, c) = angle.sin_cos();
    t * c + n.cross(t) * s + n * (n.dot(t) * (1.0 - c))
}

/// Luminance of a linear Rec.709 colour (the Y row of the RGB→XYZ matrix).
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// Largest component, used for Russian roulette and sampling weights.
pub fn max_component(c: Vec3) -> f32 {
    c.x.max(c.y).max(c.z)
}

/// True when every component is finite.
pub fn is_finite(c: Vec3) -> bool {
    c.x.is_finite() && c.y.is_finite() && c.z.is_finite()
}

/// Mirror `w` about the normal `n` (both pointing away from the surface).
pub fn reflect(w: Vec3, n: Vec3) -> Vec3 {
    2.0 * w.dot(n) * n - w
}

/// Refract `w` (pointing away from the surface, on the side `n` points to) through an interface
/// with relative index of refraction `eta = η_transmitted / η_incident`. Returns `None` on total
/// internal reflection.
pub fn refract(w: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = w.dot(n);
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(-w / eta + (cos_i / eta - cos_t) * n)
}

/// sRGB transfer function: encoded value in [0, 1] to linear.
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// sRGB transfer function: linear to encoded value (not clamped).
pub fn linear_to_srgb(v: f32) -> f32 {
    if v <= 0.0031308 {
        v * 12.92
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// γ_n = nε / (1 − nε) with ε = 2⁻²⁴, the bound on relative error after n rounded operations.
pub const fn gamma(n: i32) -> f32 {
    let e = f32::EPSILON * 0.5 * n as f32;
    e / (1.0 - e)
}

/// The transform at `time` ∈ [0, 1] along `poses` (taken at evenly spaced moments, at least
/// one): between the two nearest, scale and translation interpolated linearly and rotation
/// spherically, as Cycles interpolates decomposed motion transforms.
pub fn interpolate_transform(poses: &[Affine3A], time: f32) -> Affine3A {
    let last = poses.len().saturating_sub(1);
    if last == 0 {
        return poses.first().copied().unwrap_or(Affine3A::IDENTITY);
    }
    let x = time.clamp(0.0, 1.0) * last as f32;
    let i = (x.floor() as usize).min(last - 1);
    let f = x - i as f32;
    let (s0, r0, t0) = poses[i].to_scale_rotation_translation();
    let (s1, r1, t1) = poses[i + 1].to_scale_rotation_translation();
    Affine3A::from_scale_rotation_translation(s0.lerp(s1, f), r0.slerp(r1, f), t0.lerp(t1, f))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_are_orthonormal_for_every_direction() {
        for i in 0..1000 {
            let u = (i as f32 + 0.5) / 1000.0;
            let z = 1.0 - 2.0 * u;
            let r = (1.0 - z * z).sqrt();
            let phi = 2.399_963 * i as f32;
            let n = Vec3::new(r * phi.cos(), r * phi.sin(), z).normalize();
            let f = Frame::from_normal(n);
            assert!((f.s.length() - 1.0).abs() < 1e-5);
            assert!((f.t.length() - 1.0).abs() < 1e-5);
            assert!(
                f.s.dot(f.t).abs() < 1e-5 && f.s.dot(n).abs() < 1e-5 && f.t.dot(n).abs() < 1e-5
            );
            let v = Vec3::new(0.3, -0.2, 0.9);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
    }

    #[test]
    fn refraction_obeys_snell_and_detects_total_internal_reflection() {
        let n = Vec3::Z;
        let w = Vec3::new(0.5f32.sin(), 0.0, 0.5f32.cos());
        let t = refract(w, n, 1.5).unwrap();
        let sin_t = (t.x * t.x + t.y * t.y).sqrt();
        assert!((0.5f32.sin() - 1.5 * sin_t).abs() < 1e-5);
        assert!(t.z < 0.0);
        // From glass to air at 60°, beyond the critical angle of 41.8°.
        let w = Vec3::new(1.0f32.sin(), 0.0, 1.0f32.cos());
        assert!(refract(w, n, 1.0 / 1.5).is_none());
    }

    #[test]
    fn srgb_round_trip() {
        for i in 0..=255 {
            let v = i as f32 / 255.0;
            assert!((linear_to_srgb(srgb_to_linear(v)) - v).abs() < 1e-5);
        }
    }
}
