//! Primary rays: maps a continuous film position (pixels, origin at the top-left corner, y down)
//! to a world-space ray through the scene camera. Perspective and orthographic, as glTF defines
//! them; the vertical extent (yfov or ymag) is kept and the horizontal one follows the image
//! aspect. Blender's lens shift moves the image window in its plane, and a thin lens (Blender's
//! depth of field: aperture radius, focus distance, polygonal blades, anamorphic ratio) spreads
//! ray origins over the aperture while rays through one film point meet on the focus plane, as
//! Cycles' camera does. Cycles' panoramic cameras (equirectangular, equidistant, equisolid and
//! polynomial fisheye, mirror ball, central cylindrical, equiangular cube-map face) map the image
//! onto directions around the camera; film positions a fisheye or the mirror ball does not
//! cover give a ray that sees nothing (`Ray::t_max` 0). Rays start on Blender's clip start plane
//! and end on its clip end plane (spheres for panoramas), as Cycles' camera rays do. A camera that moves while the shutter
//! is open (Blender's motion blur) is placed, per sample, at the pose of a moment within it.

use crate::accel::{Ray, FRAME_TIME};
use crate::math::{interpolate_transform, Affine3A, Vec2, Vec3};
use crate::sampling::{square_to_disk, square_to_triangle};
use crate::scene::{Camera, Projection, ThinLens};

pub struct CameraRays {
    to_world: Affine3A,
    /// Camera space to world space at evenly spaced moments of the shutter; empty: still.
    poses: Vec<Affine3A>,
    projection: Projection,
    width: f32,
    height: f32,
    /// Half-height of the image plane at distance 1 (perspective) or in scene units (orthographic).
    half_height: f32,
    /// Offset of the image window in the image plane (same units as `half_height`).
    shift: Vec2,
    lens: Option<ThinLens>,
    /// Blender's clip start and end (`Camera::near_clip`, `far_clip`): rays start on the near
    /// plane and end on the far one, as Cycles' do.
    near_clip: f32,
    far_clip: f32,
    panoramic: bool,
}

impl CameraRays {
    pub fn new(camera: &Camera, width: u32, height: u32) -> Self {
        let half_height = match camera.projection {
            Projection::Perspective { yfov } => (0.5 * yfov).tan(),
            Projection::Orthographic { ymag, .. } => ymag,
            _ => 1.0,
        };
        let panoramic = camera.projection.is_panoramic();
        CameraRays {
            to_world: camera.to_world,
            poses: camera.motion.clone(),
            projection: camera.projection,
            width: width as f32,
            height: height as f32,
            half_height,
            shift: if panoramic {
                Vec2::ZERO
            } else {
                camera.shift * (2.0 * half_height)
            },
            lens: camera.lens.filter(|l| l.radius > 0.0 && !panoramic),
            near_clip: camera.near_clip,
            far_clip: camera.far_clip,
            panoramic,
        }
    }

    /// The direction the camera looks along (its local −Z in world space).
    pub fn forward(&self) -> Vec3 {
        self.to_world.transform_vector3(Vec3::NEG_Z).normalize()
    }

    /// Whether rays need a lens sample (`sample_ray`): the camera has an aperture.
    pub fn has_lens(&self) -> bool {
        self.lens.is_some()
    }

    /// Whether the camera moves while the shutter is open (rays need a moment: `sample_ray`).
    pub fn moves(&self) -> bool {
        !self.poses.is_empty()
    }

    /// The ray through film position `film` (in pixels) from the centre of the lens.
    pub fn ray(&self, film: Vec2) -> Ray {
        let (origin, dir) = self.camera_space_ray(film);
        self.to_world_ray(&self.to_world, origin, dir)
    }

    /// One camera sample's ray: through film position `film`, from the aperture point `lens`
    /// (uniform in the unit square) picks (ignored without an aperture), at moment `time` ∈
    /// [0, 1] of the shutter (the camera where it is then; `None`: the frame, the camera at
    /// `to_world`).
    pub fn sample_ray(&self, film: Vec2, lens: Vec2, time: Option<f32>) -> Ray {
        let to_world = match time {
            Some(t) if self.moves() => interpolate_transform(&self.poses, t),
            _ => self.to_world,
        };
        let at = |ray: Ray| Ray {
            time: time.unwrap_or(FRAME_TIME),
            ..ray
        };
        let (origin, dir) = self.camera_space_ray(film);
        let Some(thin_lens) = &self.lens else {
            return at(self.to_world_ray(&to_world, origin, dir));
        };
        // The point this ray meets on the plane in focus, at distance `focus_distance` along
        // the camera axis.
        let focus = origin + dir * (thin_lens.focus_distance / -dir.z);
        let on_lens = aperture_point(thin_lens, lens);
        let start = origin + on_lens.extend(0.0);
        at(self.to_world_ray(&to_world, start, (focus - start).normalize()))
    }

    /// The film position (pixels) of the ray from the lens centre that meets world point `p`:
    /// the inverse of `ray`, for a still perspective or orthographic camera without an aperture.
    /// `None` where no such position bounds where the camera sees `p`: a point at or behind a
    /// perspective camera's plane, a lens, a moving camera, a panorama.
    pub fn film_position(&self, p: Vec3) -> Option<Vec2> {
        if self.lens.is_some() || self.moves() {
            return None;
        }
        let q = self.to_world.inverse().transform_point3(p);
        let (x, y) = match self.projection {
            Projection::Perspective { .. } if q.z < -1e-6 * q.length() => (q.x / -q.z, q.y / -q.z),
            Projection::Orthographic { .. } => (q.x, q.y),
            _ => return None,
        };
        let aspect = self.width / self.height;
        let film = Vec2::new(
            ((x - self.shift.x) / (aspect * self.half_height) + 1.0) * 0.5 * self.width,
            (1.0 - (y - self.shift.y) / self.half_height) * 0.5 * self.height,
        );
        film.is_finite().then_some(film)
    }

    /// Origin and unit direction in camera space; a zero direction where the image shows
    /// nothing (outside a fisheye's circle).
    fn camera_space_ray(&self, film: Vec2) -> (Vec3, Vec3) {
        let aspect = self.width / self.height;
        let x = (2.0 * film.x / self.width - 1.0) * aspect * self.half_height + self.shift.x;
        let y = (1.0 - 2.0 * film.y / self.height) * self.half_height + self.shift.y;
        // Image coordinates in [0, 1], v up, for the panoramas.
        let (u, v) = (film.x / self.width, 1.0 - film.y / self.height);
        let dir = match self.projection {
            Projection::Perspective { .. } => Vec3::new(x, y, -1.0).normalize(),
            Projection::Orthographic { .. } => return (Vec3::new(x, y, 0.0), Vec3::NEG_Z),
            Projection::Equirectangular {
                longitude,
                latitude,
            } => {
                let lon = longitude.0 + u * (longitude.1 - longitude.0);
                let lat = latitude.0 + v * (latitude.1 - latitude.0);
                Vec3::new(lat.cos() * lon.sin(), lat.sin(), -lat.cos() * lon.cos())
            }
            Projection::FisheyeEquidistant { fov } => {
                let p = Vec2::new(2.0 * u - 1.0, 2.0 * v - 1.0);
                let r = p.length();
                if r > 1.0 {
                    Vec3::ZERO
                } else {
                    fisheye_direction(p, r, 0.5 * r * fov)
                }
            }
            Projection::FisheyeEquisolid { lens, fov, sensor } => {
                let p = Vec2::new((u - 0.5) * sensor.0, (v - 0.5) * sensor.1);
                let r = p.length();
                if r > 2.0 * lens * (0.25 * fov).sin() || r > 2.0 * lens {
                    Vec3::ZERO
                } else {
                    fisheye_direction(p, r, 2.0 * (r / (2.0 * lens)).asin())
                }
            }
            Projection::FisheyePolynomial { k, fov, sensor } => {
                let p = Vec2::new((u - 0.5) * sensor.0, (v - 0.5) * sensor.1);
                let r = p.length();
                let theta = -(k[0] + r * (k[1] + r * (k[2] + r * (k[3] + r * k[4]))));
                if theta.abs() > 0.5 * fov {
                    Vec3::ZERO
                } else {
                    fisheye_direction(p, r, theta)
                }
            }
            Projection::MirrorBall => mirror_ball_direction(2.0 * u - 1.0, 2.0 * v - 1.0),
            Projection::CentralCylindrical { longitude, height } => {
                let lon = longitude.0 + u * (longitude.1 - longitude.0);
                let h = height.0 + v * (height.1 - height.0);
                Vec3::new(lon.sin(), h, -lon.cos()).normalize()
            }
            Projection::CubeMapFace => {
                let quarter = std::f32::consts::FRAC_PI_2;
                Vec3::new(
                    ((u - 0.5) * quarter).tan(),
                    ((v - 0.5) * quarter).tan(),
                    -1.0,
                )
                .normalize()
            }
        };
        (Vec3::ZERO, dir)
    }

    fn to_world_ray(&self, to_world: &Affine3A, origin: Vec3, dir: Vec3) -> Ray {
        if dir == Vec3::ZERO {
            return Ray {
                origin: to_world.transform_point3(origin),
                direction: to_world.transform_vector3(Vec3::NEG_Z).normalize(),
                t_max: 0.0,
                time: FRAME_TIME,
            };
        }
        // Clip planes lie across the camera's axis (−Z); panoramas clip on spheres.
        let along = |clip: f32| match (self.panoramic, -dir.z) {
            (true, _) => clip,
            (false, cos) if cos > 0.0 => clip / cos,
            _ => f32::INFINITY,
        };
        let near = if self.near_clip > 0.0 {
            along(self.near_clip)
        } else {
            0.0
        };
        let near = if near.is_finite() { near } else { 0.0 };
        Ray {
            origin: to_world.transform_point3(origin + dir * near),
            direction: to_world.transform_vector3(dir).normalize(),
            t_max: (along(self.far_clip) - near).max(0.0),
            time: FRAME_TIME,
        }
    }
}

/// The direction at angle `theta` from the camera's −Z, towards image position `p` (at
/// distance `r` from the centre).
fn fisheye_direction(p: Vec2, r: f32, theta: f32) -> Vec3 {
    let (cos_phi, sin_phi) = if r > 0.0 {
        (p.x / r, p.y / r)
    } else {
        (1.0, 0.0)
    };
    Vec3::new(cos_phi * theta.sin(), sin_phi * theta.sin(), -theta.cos())
}

/// The direction Cycles' mirror ball maps image point (`a`, `b`) ∈ [−1, 1]² of its outline to
/// (`a` along the image's width, `b` up): the reflection of the camera's view axis (−Z) about
/// the normal (a, b, −√(1 − a² − b²)) of the unit sphere, so the centre looks along −Z, the
/// directions turning away from it twice as fast as the normal and reaching +Z at the rim; zero
/// outside the outline.
fn mirror_ball_direction(a: f32, b: f32) -> Vec3 {
    let r2 = a * a + b * b;
    if r2 > 1.0 {
        return Vec3::ZERO;
    }
    let s = (1.0 - r2).sqrt();
    Vec3::new(2.0 * s * a, 2.0 * s * b, 1.0 - 2.0 * s * s).normalize()
}

/// A point of the aperture (camera-space x, y), uniform over its area: a disk without blades,
/// else the regular polygon with `blades` corners inscribed in the disk, its first corner at
/// `rotation` from the +x axis; x is divided by the anamorphic `ratio`.
pub fn aperture_point(lens: &ThinLens, u: Vec2) -> Vec2 {
    let unit = if lens.blades < 3 {
        square_to_disk(u)
    } else {
        // Pick one of the polygon's triangles (all of equal area) with the first coordinate,
        // reuse what is left of it, and place the point uniformly in that triangle.
        let n = lens.blades as f32;
        let scaled = u.x * n;
        let k = scaled.floor().min(n - 1.0);
        let u = Vec2::new(scaled - k, u.y);
        let step = std::f32::consts::TAU / n;
        let corner = |i: f32| {
            let a = lens.rotation + i * step;
            Vec2::new(a.cos(), a.sin())
        };
        let (a, b) = (corner(k), corner(k + 1.0));
        let bary = square_to_triangle(u);
        a * bary.x + b * bary.y
    };
    lens.radius * Vec2::new(unit.x / lens.ratio, unit.y)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Quat;

    fn lens(blades: u32, ratio: f32) -> ThinLens {
        ThinLens {
            radius: 2.0,
            focus_distance: 5.0,
            blades,
            rotation: 0.3,
            ratio,
        }
    }

    /// Aperture points stay inside the disk (or polygon), are centred, and cover it evenly: the
    /// mean of r² over a uniform disk of radius R is R²/2.
    #[test]
    fn aperture_points_cover_the_aperture_uniformly() {
        for blades in [0, 3, 6] {
            let l = lens(blades, 1.0);
            let n = 64;
            let (mut sum, mut r2) = (Vec2::ZERO, 0.0);
            for i in 0..n {
                for j in 0..n {
                    let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                    let p = aperture_point(&l, u);
                    assert!(p.length() <= l.radius * 1.0001, "{p}");
                    sum += p;
                    r2 += p.length_squared();
                }
            }
            let count = (n * n) as f32;
            assert!(
                (sum / count).length() < 0.02,
                "{blades}: mean {}",
                sum / count
            );
            // Uniform over a triangle (0, a, b) with |a| = |b| = R at angle θ, the mean of |p|²
            // is R²(2 + cos θ)/6; over the disk R²/2.
            let expected = if blades == 0 {
                0.5 * l.radius * l.radius
            } else {
                let theta = std::f32::consts::TAU / blades as f32;
                l.radius * l.radius * (2.0 + theta.cos()) / 6.0
            };
            let mean_r2 = r2 / count;
            assert!(
                (mean_r2 / expected - 1.0).abs() < 0.01,
                "{blades}: {mean_r2} {expected}"
            );
        }
        let squeezed = aperture_point(&lens(0, 2.0), Vec2::new(0.999, 0.5));
        assert!(squeezed.x.abs() <= 1.0001, "{squeezed}");
    }

    /// A moving camera is at its first pose when the shutter opens, its last when it closes,
    /// and between them halfway: the position at the midpoint, the rotation half-turned.
    /// `film_position` inverts `ray` on a turned, shifted, off-square camera of either
    /// projection, and gives up where it must.
    #[test]
    fn film_position_finds_the_film_point_of_a_ray() {
        let to_world = Affine3A::from_rotation_translation(
            Quat::from_rotation_y(0.7) * Quat::from_rotation_x(-0.3),
            Vec3::new(1.0, 2.0, -3.0),
        );
        for projection in [
            Projection::Perspective { yfov: 0.8 },
            Projection::Orthographic {
                xmag: 3.0,
                ymag: 2.0,
            },
        ] {
            let camera = Camera {
                name: "c".into(),
                to_world,
                projection,
                aspect_ratio: None,
                shift: Vec2::new(0.1, -0.2),
                lens: None,
                motion: Vec::new(),
                near_clip: 0.0,
                far_clip: f32::INFINITY,
            };
            let rays = CameraRays::new(&camera, 64, 48);
            for (fx, fy, t) in [(0.5, 0.5, 1.0), (63.2, 47.9, 7.0), (20.3, 30.1, 0.3)] {
                let film = Vec2::new(fx, fy);
                let ray = rays.ray(film);
                let p = ray.origin + ray.direction * t;
                let back = rays.film_position(p).expect("in front of the camera");
                assert!(
                    back.abs_diff_eq(film, 1e-3),
                    "{projection:?}: {back} != {film}"
                );
            }
            let behind = to_world.transform_point3(Vec3::new(0.2, 0.1, 1.0));
            let perspective = matches!(projection, Projection::Perspective { .. });
            assert_eq!(rays.film_position(behind).is_none(), perspective);
            let with_lens = Camera {
                lens: Some(lens(0, 1.0)),
                ..camera.clone()
            };
            let p = to_world.transform_point3(Vec3::new(0.0, 0.0, -4.0));
            assert!(CameraRays::new(&with_lens, 64, 48)
                .film_position(p)
                .is_none());
        }
    }

    #[test]
    fn rays_run_from_the_near_clip_plane_to_the_far_one() {
        let to_world = Affine3A::from_rotation_translation(
            Quat::from_rotation_x(-0.4),
            Vec3::new(1.0, 2.0, 3.0),
        );
        let forward = to_world.transform_vector3(Vec3::NEG_Z);
        let eye: Vec3 = to_world.translation.into();
        for projection in [
            Projection::Perspective { yfov: 1.2 },
            Projection::Equirectangular {
                longitude: (-3.0, 3.0),
                latitude: (-1.5, 1.5),
            },
        ] {
            let camera = Camera {
                name: "c".into(),
                to_world,
                projection,
                aspect_ratio: None,
                shift: Vec2::ZERO,
                lens: None,
                motion: Vec::new(),
                near_clip: 0.5,
                far_clip: 10.0,
            };
            let rays = CameraRays::new(&camera, 64, 48);
            for film in [Vec2::new(32.0, 24.0), Vec2::new(3.5, 40.5)] {
                let ray = rays.ray(film);
                let start = ray.origin - eye;
                let end = start + ray.direction * ray.t_max;
                if projection.is_panoramic() {
                    // Spheres around the camera.
                    assert!((start.length() - 0.5).abs() < 1e-5, "{projection:?}");
                    assert!((end.length() - 10.0).abs() < 1e-4, "{projection:?}");
                } else {
                    // Planes across its axis.
                    assert!((start.dot(forward) - 0.5).abs() < 1e-5, "{start}");
                    assert!((end.dot(forward) - 10.0).abs() < 1e-4, "{end}");
                }
            }
        }
    }

    #[test]
    fn moving_camera_interpolates_its_poses() {
        let open = Affine3A::from_translation(Vec3::new(0.0, 0.0, 0.0));
        let close = Affine3A::from_rotation_translation(
            Quat::from_rotation_y(0.4),
            Vec3::new(2.0, 0.0, 0.0),
        );
        let camera = Camera {
            name: "c".into(),
            to_world: open,
            projection: Projection::Perspective { yfov: 0.8 },
            aspect_ratio: None,
            shift: Vec2::ZERO,
            lens: None,
            motion: vec![open, close],
            near_clip: 0.0,
            far_clip: f32::INFINITY,
        };
        let rays = CameraRays::new(&camera, 40, 30);
        assert!(rays.moves());
        let centre = Vec2::new(20.0, 15.0);
        let at = |t: f32| rays.sample_ray(centre, Vec2::ZERO, Some(t));
        assert!(at(0.0).origin.abs_diff_eq(Vec3::ZERO, 1e-6));
        assert!(at(1.0).origin.abs_diff_eq(Vec3::new(2.0, 0.0, 0.0), 1e-6));
        let middle = at(0.5);
        assert!(middle.origin.abs_diff_eq(Vec3::new(1.0, 0.0, 0.0), 1e-6));
        let turned = Quat::from_rotation_y(0.2) * Vec3::NEG_Z;
        assert!(
            middle.direction.abs_diff_eq(turned, 1e-5),
            "{}",
            middle.direction
        );
        // Without a moment the camera stays where the file puts it.
        assert!(rays
            .sample_ray(centre, Vec2::ZERO, None)
            .origin
            .abs_diff_eq(Vec3::ZERO, 1e-6));
    }

    /// Cycles' mirror ball looks along −Z at the image centre, sideways (±X, ±Y) where the
    /// sphere's normal is 45° from the view axis, back along +Z at the rim and nowhere outside
    /// it; the cube-map face spans 90° with equal angles per pixel.
    #[test]
    fn mirror_ball_and_cube_map_face_directions() {
        let s = std::f32::consts::FRAC_1_SQRT_2;
        for ((a, b), expected) in [
            ((0.0, 0.0), Vec3::NEG_Z),
            ((s, 0.0), Vec3::X),
            ((-s, 0.0), Vec3::NEG_X),
            ((0.0, s), Vec3::Y),
            ((0.0, 1.0), Vec3::Z),
        ] {
            let d = mirror_ball_direction(a, b);
            assert!(d.abs_diff_eq(expected, 1e-5), "({a}, {b}): {d}");
        }
        assert_eq!(mirror_ball_direction(0.8, 0.7), Vec3::ZERO);
        let camera = |projection| Camera {
            name: "c".into(),
            to_world: Affine3A::IDENTITY,
            projection,
            aspect_ratio: None,
            shift: Vec2::ZERO,
            lens: None,
            motion: Vec::new(),
            near_clip: 0.0,
            far_clip: f32::INFINITY,
        };
        let rays = CameraRays::new(&camera(Projection::MirrorBall), 40, 40);
        assert_eq!(rays.ray(Vec2::new(1.0, 1.0)).t_max, 0.0);
        assert!(rays
            .ray(Vec2::new(20.0, 20.0))
            .direction
            .abs_diff_eq(Vec3::NEG_Z, 1e-5));
        let face = CameraRays::new(&camera(Projection::CubeMapFace), 90, 90);
        for (x, degrees) in [(0.0, -45.0f32), (30.0, -15.0), (45.0, 0.0), (90.0, 45.0)] {
            let d = face.ray(Vec2::new(x, 45.0)).direction;
            let angle = d.x.atan2(-d.z).to_degrees();
            assert!((angle - degrees).abs() < 1e-3, "{x}: {angle}");
        }
    }

    /// Every ray through one film point meets the others on the plane in focus.
    #[test]
    fn rays_through_the_lens_meet_on_the_focus_plane() {
        let camera = Camera {
            name: "c".into(),
            to_world: Affine3A::from_translation(Vec3::new(1.0, 2.0, 3.0)),
            projection: Projection::Perspective { yfov: 0.8 },
            aspect_ratio: None,
            shift: Vec2::new(0.1, -0.2),
            lens: Some(lens(5, 1.0)),
            motion: Vec::new(),
            near_clip: 0.0,
            far_clip: f32::INFINITY,
        };
        let rays = CameraRays::new(&camera, 40, 30);
        let film = Vec2::new(7.3, 21.8);
        let centre = rays.ray(film);
        let focus_z = 3.0 - 5.0;
        let at_focus = |r: &Ray| r.origin + r.direction * ((focus_z - r.origin.z) / r.direction.z);
        let target = at_focus(&centre);
        for u in [
            Vec2::new(0.1, 0.9),
            Vec2::new(0.7, 0.2),
            Vec2::new(0.45, 0.55),
        ] {
            let r = rays.sample_ray(film, u, None);
            assert!((r.origin - centre.origin).length() > 1e-3);
            assert!((at_focus(&r) - target).length() < 1e-4, "{}", at_focus(&r));
        }
    }
}
