"""PHOTON_camera: what glTF's camera cannot say about a Blender camera, as Cycles renders it.

Lens shift, depth of field as a thin lens, the panoramic projections Photon renders, and the
camera's motion over the shutter (recorded by motion.py and passed in). It imports nothing of
the add-on's: it runs in the export's child process too.
"""

from __future__ import annotations


def camera_extension(obj, scene, motion: list | None = None) -> dict:
    """PHOTON_camera for a camera object: the lens shift in units of the image height, and depth
    of field as a thin lens (aperture radius, focus distance, blades, rotation, ratio), the way
    Cycles derives them from Blender's camera; `motion`, the camera's poses over the shutter
    (motion.SHUTTER_POSES), when it moves. Empty for a centred pinhole camera."""
    camera, data = obj.data, {}
    r = scene.render
    width = r.resolution_x * r.pixel_aspect_x
    height = r.resolution_y * r.pixel_aspect_y
    fit = camera.sensor_fit
    if fit == "AUTO":
        fit = "HORIZONTAL" if width >= height else "VERTICAL"
    # Blender's shift is a fraction of the fitted image side; Photon's of the image height.
    unit = width / height if fit == "HORIZONTAL" else 1.0
    if camera.shift_x != 0.0 or camera.shift_y != 0.0:
        data["shift"] = [float(camera.shift_x * unit), float(camera.shift_y * unit)]
    if camera.type == "PANO":
        panorama = panorama_extension(camera, width, height)
        if panorama:
            data["panorama"] = panorama
        return data
    if motion:
        data["motion"] = motion
    dof = camera.dof
    if dof.use_dof:
        fstop = max(float(dof.aperture_fstop), 1e-5)
        if camera.type == "ORTHO":
            radius = 1.0 / (2.0 * fstop)
        else:
            radius = float(camera.lens) * 1e-3 / (2.0 * fstop)
        data["dof"] = {"aperture_radius": radius,
                       "focus_distance": max(focus_distance(obj), 1e-6),
                       "blades": int(dof.aperture_blades),
                       "rotation": float(dof.aperture_rotation),
                       "ratio": float(dof.aperture_ratio)}
    return data


# The panoramic projections PHOTON_camera carries (the others are named by the pre-flight).
PANORAMAS = ("EQUIRECTANGULAR", "FISHEYE_EQUIDISTANT", "FISHEYE_EQUISOLID",
             "FISHEYE_LENS_POLYNOMIAL", "MIRRORBALL", "EQUIANGULAR_CUBEMAP_FACE",
             "CENTRAL_CYLINDRICAL")


def panorama_extension(camera, width: float, height: float) -> dict:
    """The "panorama" of PHOTON_camera for a panoramic camera (Cycles' projection and its
    parameters; the equisolid and polynomial fisheyes' sensor fitted to an image of `width` x
    `height` as Cycles fits it); empty for a projection Photon does not render."""
    kind = camera.panorama_type
    if kind == "EQUIRECTANGULAR":
        return {"type": kind,
                "longitude": [float(camera.longitude_min), float(camera.longitude_max)],
                "latitude": [float(camera.latitude_min), float(camera.latitude_max)]}
    if kind == "FISHEYE_EQUIDISTANT":
        return {"type": kind, "fov": float(camera.fisheye_fov)}
    if kind in ("FISHEYE_EQUISOLID", "FISHEYE_LENS_POLYNOMIAL"):
        fit = camera.sensor_fit
        horizontal = width > height if fit == "AUTO" else fit == "HORIZONTAL"
        size = float(camera.sensor_height if fit == "VERTICAL" else camera.sensor_width)
        sensor = [size, size * height / width] if horizontal else [size * width / height, size]
        if kind == "FISHEYE_LENS_POLYNOMIAL":
            k = [float(getattr(camera, f"fisheye_polynomial_k{i}")) for i in range(5)]
            return {"type": kind, "k": k, "fov": float(camera.fisheye_fov), "sensor": sensor}
        return {"type": kind, "lens": float(camera.fisheye_lens),
                "fov": float(camera.fisheye_fov), "sensor": sensor}
    if kind == "CENTRAL_CYLINDRICAL":
        # Heights on the cylinder in units of its radius, as Cycles takes them.
        radius = max(float(camera.central_cylindrical_radius), 1e-6)
        return {"type": kind,
                "longitude": [float(camera.central_cylindrical_range_u_min),
                              float(camera.central_cylindrical_range_u_max)],
                "height": [float(camera.central_cylindrical_range_v_min) / radius,
                           float(camera.central_cylindrical_range_v_max) / radius]}
    if kind in ("MIRRORBALL", "EQUIANGULAR_CUBEMAP_FACE"):
        return {"type": kind}
    return {}


def focus_distance(obj) -> float:
    """The camera's focus distance: to its focus object (bone heads are not followed) along the
    camera axis, measured in the camera's unscaled frame as Cycles does, else the distance set."""
    dof = obj.data.dof
    target = dof.focus_object
    if target is None:
        return float(dof.focus_distance)
    frame = obj.matrix_world.normalized()
    local = frame.inverted() @ target.matrix_world.translation
    return abs(float(local.z))

