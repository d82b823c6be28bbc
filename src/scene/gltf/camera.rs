//! Cameras: glTF's perspective and orthographic cameras with `PHOTON_camera`'s lens shift, thin
//! lens, panoramic projections and motion, and the camera that frames a scene without one.

use super::motion::read_poses;
use crate::math::{Affine3A, Mat3, Mat4, Vec2, Vec3};
use crate::scene::{Bounds, Camera, Projection, ThinLens};
use serde_json::Value;

/// A camera found while walking the node tree.
pub(super) struct FoundCamera {
    pub(super) node_name: String,
    pub(super) camera_name: String,
    pub(super) camera: Camera,
}

pub(super) fn convert_camera(
    node: &gltf::Node,
    camera: &gltf::Camera,
    world: &Mat4,
) -> std::result::Result<Camera, String> {
    let (_, rotation, translation) = world.to_scale_rotation_translation();
    let near_clip = match camera.projection() {
        gltf::camera::Projection::Perspective(p) => p.znear(),
        gltf::camera::Projection::Orthographic(o) => o.znear(),
    };
    let near_clip = if near_clip.is_finite() && near_clip > 0.0 {
        near_clip
    } else {
        0.0
    };
    let (projection, aspect_ratio) = match camera.projection() {
        gltf::camera::Projection::Perspective(p) => {
            let yfov = p.yfov();
            if !(yfov > 0.0 && yfov < std::f32::consts::PI) {
                return Err(format!(
                    "perspective yfov {yfov} is not an angle in (0, π) radians"
                ));
            }
            (Projection::Perspective { yfov }, p.aspect_ratio())
        }
        gltf::camera::Projection::Orthographic(o) => {
            let (xmag, ymag) = (o.xmag(), o.ymag());
            if !(xmag > 0.0 && ymag > 0.0 && xmag.is_finite() && ymag.is_finite()) {
                return Err(format!(
                    "orthographic xmag {xmag} and ymag {ymag} must be positive and finite"
                ));
            }
            (Projection::Orthographic { xmag, ymag }, Some(xmag / ymag))
        }
    };
    if let Some(a) = aspect_ratio {
        if !(a > 0.0 && a.is_finite()) {
            return Err(format!("aspectRatio {a} must be positive and finite"));
        }
    }
    Ok(Camera {
        name: node
            .name()
            .or(camera.name())
            .map_or_else(|| format!("camera {}", camera.index()), str::to_string),
        to_world: Affine3A::from_rotation_translation(rotation.normalize(), translation),
        projection,
        aspect_ratio,
        shift: Vec2::ZERO,
        lens: None,
        motion: Vec::new(),
        near_clip,
    })
}

/// `PHOTON_camera` (see the module documentation) applied to `camera`.
pub(super) fn read_camera_extension(
    value: &Value,
    camera: &mut Camera,
) -> std::result::Result<(), String> {
    let number =
        |object: &Value, key: &str, default: f32, ok: fn(f32) -> bool| match object.get(key) {
            None => Ok(default),
            Some(v) => match v.as_f64().map(|x| x as f32) {
                Some(x) if x.is_finite() && ok(x) => Ok(x),
                _ => Err(format!("'{key}' is out of range: {v}")),
            },
        };
    if let Some(v) = value.get("shift") {
        camera.shift = match v.as_array().map(Vec::as_slice) {
            Some([x, y]) => match (x.as_f64(), y.as_f64()) {
                (Some(x), Some(y)) => Vec2::new(x as f32, y as f32),
                _ => return Err(format!("'shift' must be two numbers, found {v}")),
            },
            _ => return Err(format!("'shift' must be two numbers, found {v}")),
        };
        if !camera.shift.is_finite() {
            return Err(format!("'shift' must be finite, found {v}"));
        }
    }
    if let Some(panorama) = value.get("panorama") {
        camera.projection = read_panorama(panorama)?;
    }
    if let Some(v) = value.get("motion") {
        // Cameras are rigid: the scale goes.
        camera.motion = read_poses(v)?
            .into_iter()
            .map(|m| {
                let (_, rotation, translation) = m.to_scale_rotation_translation();
                Affine3A::from_rotation_translation(rotation.normalize(), translation)
            })
            .collect();
    }
    if let Some(dof) = value.get("dof") {
        let radius = number(dof, "aperture_radius", 0.0, |x| x >= 0.0)?;
        let focus_distance = number(dof, "focus_distance", 10.0, |x| x > 0.0)?;
        let blades = number(dof, "blades", 0.0, |x| (0.0..=1000.0).contains(&x))?;
        let rotation = number(dof, "rotation", 0.0, |_| true)?;
        let ratio = number(dof, "ratio", 1.0, |x| x > 0.0)?;
        camera.lens = (radius > 0.0).then_some(ThinLens {
            radius,
            focus_distance,
            blades: blades as u32,
            rotation,
            ratio,
        });
    }
    Ok(())
}

/// The `panorama` of `PHOTON_camera`: Cycles' equirectangular or fisheye projection.
pub(super) fn read_panorama(value: &Value) -> std::result::Result<Projection, String> {
    let pair = |key: &str, default: (f32, f32), ok: fn(f32) -> bool| match value.get(key) {
        None => Ok(default),
        Some(v) => match v.as_array().map(Vec::as_slice) {
            Some([a, b]) => match (a.as_f64(), b.as_f64()) {
                (Some(a), Some(b)) if ok(a as f32) && ok(b as f32) => Ok((a as f32, b as f32)),
                _ => Err(format!("'{key}' is out of range: {v}")),
            },
            _ => Err(format!("'{key}' must be two numbers, found {v}")),
        },
    };
    let number = |key: &str, default: f32| match value.get(key) {
        None => Ok(default),
        Some(v) => match v.as_f64().map(|x| x as f32) {
            Some(x) if x.is_finite() && x > 0.0 => Ok(x),
            _ => Err(format!("'{key}' must be a positive number, found {v}")),
        },
    };
    let pi = std::f32::consts::PI;
    match value.get("type").and_then(Value::as_str) {
        Some("EQUIRECTANGULAR") => Ok(Projection::Equirectangular {
            longitude: pair("longitude", (-pi, pi), |x| x.is_finite())?,
            latitude: pair("latitude", (-0.5 * pi, 0.5 * pi), |x| x.is_finite())?,
        }),
        Some("FISHEYE_EQUIDISTANT") => Ok(Projection::FisheyeEquidistant {
            fov: number("fov", pi)?,
        }),
        Some("FISHEYE_EQUISOLID") => Ok(Projection::FisheyeEquisolid {
            lens: number("lens", 10.5)?,
            fov: number("fov", pi)?,
            sensor: pair("sensor", (36.0, 24.0), |x| x.is_finite() && x > 0.0)?,
        }),
        other => Err(format!(
            "unknown panorama type {other:?} (EQUIRECTANGULAR, FISHEYE_EQUIDISTANT or \
             FISHEYE_EQUISOLID)"
        )),
    }
}

/// A 40° perspective camera in front of the bounds (+Z side, slightly above), looking at their
/// centre from far enough that the bounding sphere fits in the view.
pub(super) fn framing_camera(bounds: Bounds) -> Camera {
    let yfov = 40f32.to_radians();
    let (center, radius) = if bounds.is_empty() {
        (Vec3::ZERO, 1.0)
    } else {
        (bounds.center(), (0.5 * bounds.diagonal()).max(1e-3))
    };
    let distance = 1.1 * radius / (0.5 * yfov).sin();
    let eye = center + distance * Vec3::new(0.0, 0.3, 1.0).normalize();
    Camera {
        name: "framing camera".into(),
        to_world: look_at(eye, center),
        projection: Projection::Perspective { yfov },
        aspect_ratio: None,
        shift: Vec2::ZERO,
        lens: None,
        motion: Vec::new(),
        near_clip: 0.0,
    }
}

/// Camera-to-world transform of a camera at `eye` looking at `target` (−Z forward, +Y up).
pub(super) fn look_at(eye: Vec3, target: Vec3) -> Affine3A {
    let back = (eye - target).normalize_or(Vec3::Z);
    let right = Vec3::Y.cross(back).normalize_or(Vec3::X);
    let up = back.cross(right);
    Affine3A::from_mat3_translation(Mat3::from_cols(right, up, back), eye)
}
