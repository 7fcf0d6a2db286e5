# SPDX-License-Identifier: GPL-3.0-or-later
"""The camera: the scene camera's optics, resolution and matrices for a frame, and its
thin lens (Depth of Field)."""
from __future__ import annotations

import numpy as np

from ...hybrid_engine.scene.camera import Camera, CameraError
from ...hybrid_engine.scene.thin_lens import ThinLens

# Lens Blender uses when the scene camera is not a camera object (BKE_camera_params_from_object).
NON_CAMERA_LENS = 35.0


def _matrix(instance_or_object) -> np.ndarray:
    return np.array(instance_or_object.matrix_world, np.float64)


def render_resolution(render) -> tuple[int, int]:
    """The frame's size in pixels as Blender's render pipeline computes it
    (``BKE_render_resolution``: integer arithmetic, resolution * percentage / 100). A float
    scale gets some sizes one pixel short (100 px at 29 % is 28.999... px), and Blender then
    refuses the image."""
    percentage = int(render.resolution_percentage)
    return (max(int(render.resolution_x) * percentage // 100, 1),
            max(int(render.resolution_y) * percentage // 100, 1))


def camera_from_scene(scene, depsgraph=None) -> Camera:
    """The scene camera (evaluated when a depsgraph is given) and the render resolution.

    Raises ``CameraError`` when the scene has no camera or uses a panoramic one.
    """
    camera_object = scene.camera
    if camera_object is None:
        raise CameraError(f"scene {scene.name!r} has no active camera: set one in Scene "
                          "Properties > Camera")
    if depsgraph is not None:
        camera_object = camera_object.evaluated_get(depsgraph)
    render = scene.render
    width, height = render_resolution(render)
    common = dict(
        matrix_world=_matrix(camera_object),
        width=width,
        height=height,
        pixel_aspect_x=float(render.pixel_aspect_x),
        pixel_aspect_y=float(render.pixel_aspect_y),
    )
    if camera_object.type != "CAMERA":  # Blender renders from any object, with default optics
        return Camera(lens=NON_CAMERA_LENS, **common)
    data = camera_object.data
    if data.type not in ("PERSP", "ORTHO"):
        raise CameraError(
            f"camera {camera_object.name!r} is {data.type}: Hybrid RT renders perspective and "
            "orthographic cameras only"
        )
    return Camera(
        projection=data.type,
        lens=float(data.lens),
        sensor_width=float(data.sensor_width),
        sensor_height=float(data.sensor_height),
        sensor_fit=data.sensor_fit,
        shift_x=float(data.shift_x),
        shift_y=float(data.shift_y),
        clip_start=float(data.clip_start),
        clip_end=float(data.clip_end),
        ortho_scale=float(data.ortho_scale),
        **common,
    )


def focus_distance(camera_object, dof) -> float:
    """The distance the camera is focused at, as Cycles resolves it
    (``blender_camera_focal_distance``): with a focus object (and bone), that point's
    distance along the camera's view axis; otherwise the panel's Distance."""
    target = dof.focus_object
    if target is None:
        return float(dof.focus_distance)
    point = np.array(target.matrix_world, np.float64)[:3, 3]
    bone_name = getattr(dof, "focus_subtarget", "")
    if bone_name and target.pose is not None and bone_name in target.pose.bones:
        bone_matrix = np.array(target.matrix_world, np.float64) @ np.array(target.pose.bones[bone_name].matrix,
                                                                           np.float64)
        point = bone_matrix[:3, 3]
    matrix = _matrix(camera_object)
    view_axis = matrix[:3, 2] / max(float(np.linalg.norm(matrix[:3, 2])), 1e-30)
    return abs(float(view_axis @ (matrix[:3, 3] - point)))


def thin_lens_from_scene(scene, depsgraph=None) -> ThinLens | None:
    """The scene camera's Depth of Field as a thin lens (scene/thin_lens.py, Cycles' aperture),
    or None when its Depth of Field is off (or the camera is no camera object)."""
    camera_object = scene.camera
    if camera_object is None or camera_object.type != "CAMERA":
        return None
    if depsgraph is not None:
        camera_object = camera_object.evaluated_get(depsgraph)
    data = camera_object.data
    dof = data.dof
    if not dof.use_dof or data.type not in ("PERSP", "ORTHO"):
        return None
    return ThinLens.from_blender(float(data.lens), float(dof.aperture_fstop), focus_distance(camera_object, dof),
                                 blades=int(dof.aperture_blades), rotation=float(dof.aperture_rotation),
                                 ratio=float(dof.aperture_ratio), orthographic=data.type == "ORTHO")
