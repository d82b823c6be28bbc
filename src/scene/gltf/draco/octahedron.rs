//! Octahedral unit vectors as Draco stores normals (Meyer et al. 2010, "On floating-point
//! normal vectors"; Cigolle et al. 2014, "A survey of efficient representations for
//! independent unit vectors"; Draco bitstream specification 2.2, "Normal octahedron
//! transform"): the (s, t) square of `bits`-bit coordinates, its canonical form, the diamond
//! inversion and rotations the canonicalized prediction transform uses, and the conversion back
//! to a unit vector.

/// The octahedral square of one quantization.
#[derive(Clone, Copy)]
pub(super) struct Octahedron {
    pub(super) max_quantized: i32,
    max_value: i32,
    pub(super) center: i32,
}

impl Octahedron {
    /// The square of `bits` bits (2 to 30), or `None` outside Draco's range.
    pub(super) fn new(bits: u32) -> Option<Octahedron> {
        if !(2..=30).contains(&bits) {
            return None;
        }
        let max_quantized = (1i32 << bits) - 1;
        let max_value = max_quantized - 1;
        Some(Octahedron {
            max_quantized,
            max_value,
            center: max_value / 2,
        })
    }

    /// The unit vector at quantized coordinates (s, t).
    pub(super) fn unit_vector(&self, s: i32, t: i32) -> [f32; 3] {
        let scale = 2.0 / self.max_value as f32;
        let mut y = s as f32 * scale - 1.0;
        let mut z = t as f32 * scale - 1.0;
        let x = 1.0 - y.abs() - z.abs();
        let x_offset = (-x).max(0.0);
        y += if y < 0.0 { x_offset } else { -x_offset };
        z += if z < 0.0 { x_offset } else { -x_offset };
        let norm2 = x * x + y * y + z * z;
        if norm2 < 1e-6 {
            return [0.0; 3];
        }
        let d = 1.0 / norm2.sqrt();
        [x * d, y * d, z * d]
    }

    /// Scale an integer vector so its absolute components sum to the centre value.
    pub(super) fn canonicalize_vector(&self, v: [i64; 3]) -> [i32; 3] {
        let sum = v[0].abs() + v[1].abs() + v[2].abs();
        if sum == 0 {
            return [self.center, 0, 0];
        }
        let c = i64::from(self.center);
        let x = (v[0] * c / sum) as i32;
        let y = (v[1] * c / sum) as i32;
        let rest = self.center - x.abs() - y.abs();
        [x, y, if v[2] >= 0 { rest } else { -rest }]
    }

    /// The quantized octahedral coordinates of an integer vector whose absolute components
    /// sum to the centre value.
    pub(super) fn vector_to_coords(&self, v: [i32; 3]) -> (i32, i32) {
        let (s, t) = if v[0] >= 0 {
            (v[1] + self.center, v[2] + self.center)
        } else {
            let s = if v[1] < 0 {
                v[2].abs()
            } else {
                self.max_value - v[2].abs()
            };
            let t = if v[2] < 0 {
                v[1].abs()
            } else {
                self.max_value - v[1].abs()
            };
            (s, t)
        };
        self.canonicalize_coords(s, t)
    }

    fn canonicalize_coords(&self, mut s: i32, mut t: i32) -> (i32, i32) {
        let (m, c) = (self.max_value, self.center);
        let corner = (s == 0 && (t == 0 || t == m)) || (s == m && t == 0);
        if corner {
            s = m;
            t = m;
        } else if s == 0 && t > c {
            t = c - (t - c);
        } else if s == m && t < c {
            t = c + (c - t);
        } else if t == m && s < c {
            s = c + (c - s);
        } else if t == 0 && s > c {
            s = c - (s - c);
        }
        (s, t)
    }

    pub(super) fn in_diamond(&self, s: i32, t: i32) -> bool {
        s.abs() + t.abs() <= self.center
    }

    pub(super) fn invert_diamond(&self, s: &mut i32, t: &mut i32) {
        let (sign_s, sign_t) = if *s >= 0 && *t >= 0 {
            (1, 1)
        } else if *s <= 0 && *t <= 0 {
            (-1, -1)
        } else {
            (if *s > 0 { 1 } else { -1 }, if *t > 0 { 1 } else { -1 })
        };
        let (cs, ct) = (sign_s * self.center, sign_t * self.center);
        let mut ns = 2 * *s - cs;
        let mut nt = 2 * *t - ct;
        if sign_s * sign_t >= 0 {
            let tmp = ns;
            ns = -nt;
            nt = -tmp;
        } else {
            std::mem::swap(&mut ns, &mut nt);
        }
        *s = (ns + cs) / 2;
        *t = (nt + ct) / 2;
    }

    /// A correction brought back into (−centre, centre].
    pub(super) fn mod_max(&self, x: i32) -> i32 {
        if x > self.center {
            x - self.max_quantized
        } else if x < -self.center {
            x + self.max_quantized
        } else {
            x
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_centre_is_plus_x_and_vectors_round_trip_through_their_coordinates() {
        let o = Octahedron::new(10).unwrap();
        let [x, y, z] = o.unit_vector(o.center, o.center);
        assert!((x - 1.0).abs() < 1e-6 && y.abs() < 1e-6 && z.abs() < 1e-6);
        for v in [[3i64, -4, 5], [-7, 2, -1], [0, 0, -9], [-1, 5, 3]] {
            let q = o.canonicalize_vector(v);
            assert_eq!(q[0].abs() + q[1].abs() + q[2].abs(), o.center);
            let (s, t) = o.vector_to_coords(q);
            let n = o.unit_vector(s, t);
            let len = ((v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) as f32).sqrt();
            for k in 0..3 {
                assert!((n[k] - v[k] as f32 / len).abs() < 0.02, "{v:?} -> {n:?}");
            }
        }
        assert!(Octahedron::new(1).is_none() && Octahedron::new(31).is_none());
    }
}
