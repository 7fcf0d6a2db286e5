# SPDX-License-Identifier: GPL-3.0-or-later
"""hybrid_engine.scene.camera against Blender's own camera math (calc_matrix_camera)."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from hybrid_engine.scene.camera import Camera, CameraError, look_at, perspective_matrix

# Blender computes its matrices in float32; relative agreement to this is exact enough.
MATRIX_RTOL = 1e-5


def blender_projection(width, height, aspx, aspy, **cam):
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    data = bpy.data.cameras.new("cam")
    for key, value in cam.items():
        setattr(data, key, value)
    obj = bpy.data.objects.new("cam", data)
    bpy.context.scene.collection.objects.link(obj)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    m = obj.calc_matrix_camera(depsgraph, x=width, y=height, scale_x=aspx, scale_y=aspy)
    return np.array(m, np.float64)


CASES = [
    dict(type="PERSP", lens=50.0, sensor_fit="AUTO", shift_x=0.0, shift_y=0.0),
    dict(type="PERSP", lens=24.0, sensor_fit="HORIZONTAL", shift_x=0.1, shift_y=-0.2),
    dict(type="PERSP", lens=85.0, sensor_fit="VERTICAL", shift_x=-0.3, shift_y=0.05, sensor_height=18.0),
    dict(type="ORTHO", ortho_scale=7.5, sensor_fit="AUTO", shift_x=0.2, shift_y=0.1),
    dict(type="ORTHO", ortho_scale=3.0, sensor_fit="VERTICAL", shift_x=0.0, shift_y=0.3),
]
SIZES = [(640, 360, 1.0, 1.0), (300, 500, 1.0, 1.0), (320, 240, 2.0, 1.0)]


@pytest.mark.parametrize("cam,size", list(itertools.product(CASES, SIZES)))
def test_projection_matches_blender_calc_matrix_camera(cam, size):
    width, height, aspx, aspy = size
    blender_cam = dict(cam, clip_start=0.25, clip_end=250.0)
    expected = blender_projection(width, height, aspx, aspy, **blender_cam)
    ours = Camera(
        width=width, height=height, pixel_aspect_x=aspx, pixel_aspect_y=aspy,
        projection=cam["type"], lens=cam.get("lens", 50.0), sensor_width=cam.get("sensor_width", 36.0),
        sensor_height=cam.get("sensor_height", 24.0), sensor_fit=cam["sensor_fit"],
        shift_x=cam["shift_x"], shift_y=cam["shift_y"], clip_start=0.25, clip_end=250.0,
        ortho_scale=cam.get("ortho_scale", 6.0),
    ).projection_matrix()
    np.testing.assert_allclose(ours, expected, rtol=MATRIX_RTOL, atol=1e-6)


def test_view_matrix_inverts_the_camera_world_matrix_without_scale():
    world = look_at((3.0, -4.0, 2.0), (0.0, 0.0, 0.5))
    scaled = world.copy()
    scaled[:3, :3] *= 2.5  # object scale must not change the view
    cam = Camera(matrix_world=scaled)
    np.testing.assert_allclose(cam.view_matrix() @ world, np.eye(4), atol=1e-12)


def test_pixel_rays_hit_the_pixel_centres_they_project_to():
    cam = Camera(matrix_world=look_at((1, -5, 2), (0, 0, 0)), width=8, height=6, shift_x=0.1)
    origins, dirs = cam.pixel_rays()
    points = origins + dirs * 3.0
    clip = np.c_[points.reshape(-1, 3), np.ones(48)] @ cam.view_projection().T
    ndc = clip[:, :2] / clip[:, 3:4]
    px = ((ndc + 1) / 2 * [8, 6] - 0.5).reshape(6, 8, 2)
    ys, xs = np.mgrid[0:6, 0:8]
    np.testing.assert_allclose(px[..., 0], xs, atol=1e-6)
    np.testing.assert_allclose(px[..., 1], ys, atol=1e-6)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(width=0), "at least 1x1"),
        (dict(clip_start=2.0, clip_end=1.0), "clip range"),
        (dict(projection="PANO"), "projection"),
        (dict(matrix_world=np.full((4, 4), np.nan)), "finite"),
        (dict(lens=0.0), "focal length"),
    ],
)
def test_bad_camera_parameters_fail_with_a_clear_message(kwargs, match):
    with pytest.raises(CameraError, match=match):
        Camera(**kwargs)


def test_perspective_matrix_maps_near_and_far_to_ndc_bounds():
    p = perspective_matrix(np.radians(90.0), 1.0, 0.5, 20.0)
    for z, expected in ((-0.5, -1.0), (-20.0, 1.0)):
        clip = p @ np.array([0.0, 0.0, z, 1.0])
        assert clip[2] / clip[3] == pytest.approx(expected)
