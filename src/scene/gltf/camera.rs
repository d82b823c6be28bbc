//! Cameras: glTF's perspective and orthographic cameras with `PHOTON_camera`'s lens shift, thin
//! lens, panoramic projections and motion, and the camera that frames a scene without one.

use super::container::named;
use super::extensions::CameraExtension;
use crate::math::{Affine3A, Mat3, Mat4, Vec2, Vec3};
use crate::scene::{Bounds, Camera, Projection};

/// A camera found while walking the node tree.
pub(super) struct FoundCamera {
    pub(super) node_name: String,
    pub(super) camera_name: String,
    pub(super) camera: Camera,
}

/// The camera `node` holds, with its `PHOTON_camera` applied: its glTF camera, or a panoramic
/// camera (Blender's exporter drops those and keeps their node, with a `panorama`). An error
/// names the glTF camera at fault.
pub(super) fn node_camera(
    node: &gltf::Node,
    world: &Mat4,
    extension: Option<&CameraExtension>,
) -> std::result::Result<Option<FoundCamera>, (String, String)> {
    let mut found = match node.camera() {
        Some(camera) => FoundCamera {
            node_name: node.name().unwrap_or_default().to_string(),
            camera_name: camera.name().unwrap_or_default().to_string(),
            camera: convert_camera(node, &camera, world)
                .map_err(|m| (named("camera", camera.index(), camera.name()), m))?,
        },
        None if extension.is_some_and(|e| e.panorama.is_some()) => {
            let name = node.name().unwrap_or("panoramic camera").to_string();
            let placeholder = Projection::Perspective { yfov: 0.6981 };
            FoundCamera {
                node_name: name.clone(),
                camera_name: name.clone(),
                camera: rigid_camera(name, world, placeholder, None, 0.0, f32::INFINITY),
            }
        }
        None => return Ok(None),
    };
    if let Some(extension) = extension {
        let camera = &mut found.camera;
        camera.shift = extension.shift;
        camera.lens = extension.lens;
        camera.motion = extension.motion.clone();
        if let Some(panorama) = extension.panorama {
            camera.projection = panorama;
        }
    }
    Ok(Some(found))
}

/// A camera placed by `world` without its scale, with no shift, lens or motion.
fn rigid_camera(
    name: String,
    world: &Mat4,
    projection: Projection,
    aspect_ratio: Option<f32>,
    near_clip: f32,
    far_clip: f32,
) -> Camera {
    let (_, rotation, translation) = world.to_scale_rotation_translation();
    Camera {
        name,
        to_world: Affine3A::from_rotation_translation(rotation.normalize(), translation),
        projection,
        aspect_ratio,
        shift: Vec2::ZERO,
        lens: None,
        motion: Vec::new(),
        near_clip,
        far_clip,
    }
}

/// glTF's perspective or orthographic camera, its values checked.
fn convert_camera(
    node: &gltf::Node,
    camera: &gltf::Camera,
    world: &Mat4,
) -> std::result::Result<Camera, String> {
    let near_clip = match camera.projection() {
        gltf::camera::Projection::Perspective(p) => p.znear(),
        gltf::camera::Projection::Orthographic(o) => o.znear(),
    };
    let near_clip = if near_clip.is_finite() && near_clip > 0.0 {
        near_clip
    } else {
        0.0
    };
    // No far plane (an infinite projection) or one not beyond the near plane: nothing clipped.
    let far_clip = match camera.projection() {
        gltf::camera::Projection::Perspective(p) => p.zfar(),
        gltf::camera::Projection::Orthographic(o) => Some(o.zfar()),
    }
    .filter(|&far| far.is_finite() && far > near_clip)
    .unwrap_or(f32::INFINITY);
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
    let name = node
        .name()
        .or(camera.name())
        .map_or_else(|| format!("camera {}", camera.index()), str::to_string);
    Ok(rigid_camera(
        name,
        world,
        projection,
        aspect_ratio,
        near_clip,
        far_clip,
    ))
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
        far_clip: f32::INFINITY,
    }
}

/// Camera-to-world transform of a camera at `eye` looking at `target` (−Z forward, +Y up).
pub(super) fn look_at(eye: Vec3, target: Vec3) -> Affine3A {
    let back = (eye - target).normalize_or(Vec3::Z);
    let right = Vec3::Y.cross(back).normalize_or(Vec3::X);
    let up = back.cross(right);
    Affine3A::from_mat3_translation(Mat3::from_cols(right, up, back), eye)
}
