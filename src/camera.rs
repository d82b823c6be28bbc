//! Primary rays: maps a continuous film position (pixels, origin at the top-left corner, y down)
//! to a world-space ray through the scene camera. Perspective and orthographic, as glTF defines
//! them; the vertical extent (yfov or ymag) is kept and the horizontal one follows the image aspect.

use crate::accel::Ray;
use crate::math::{Affine3A, Vec2, Vec3};
use crate::scene::{Camera, Projection};

pub struct CameraRays {
    to_world: Affine3A,
    projection: Projection,
    width: f32,
    height: f32,
    /// Half-height of the image plane at distance 1 (perspective) or in scene units (orthographic).
    half_height: f32,
}

impl CameraRays {
    pub fn new(camera: &Camera, width: u32, height: u32) -> Self {
        let half_height = match camera.projection {
            Projection::Perspective { yfov } => (0.5 * yfov).tan(),
            Projection::Orthographic { ymag, .. } => ymag,
        };
        CameraRays {
            to_world: camera.to_world,
            projection: camera.projection,
            width: width as f32,
            height: height as f32,
            half_height,
        }
    }

    /// The direction the camera looks along (its local −Z in world space).
    pub fn forward(&self) -> Vec3 {
        self.to_world.transform_vector3(Vec3::NEG_Z).normalize()
    }

    /// The ray through film position `film` (in pixels).
    pub fn ray(&self, film: Vec2) -> Ray {
        let aspect = self.width / self.height;
        let x = (2.0 * film.x / self.width - 1.0) * aspect * self.half_height;
        let y = (1.0 - 2.0 * film.y / self.height) * self.half_height;
        let (origin, dir) = match self.projection {
            Projection::Perspective { .. } => (Vec3::ZERO, Vec3::new(x, y, -1.0).normalize()),
            Projection::Orthographic { .. } => (Vec3::new(x, y, 0.0), Vec3::NEG_Z),
        };
        Ray {
            origin: self.to_world.transform_point3(origin),
            direction: self.to_world.transform_vector3(dir).normalize(),
            t_max: f32::INFINITY,
        }
    }
}
