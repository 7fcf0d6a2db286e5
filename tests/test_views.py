# SPDX-License-Identifier: GPL-3.0-or-later
"""hybrid_engine.frame.views and frame.viewport: region matrices → a renderable view, its crops and the frame plan.

Oracles: the core ``Camera`` (whose matrices follow Blender's BKE_camera code and have their
own tests), Blender's own ``Object.calc_matrix_camera`` for the region matrices Blender would
hand to ``view_draw``, and the renderer itself (a view built from matrices must render the
very image of the camera it came from).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from hybrid_engine.scene.camera import Camera, look_at
from hybrid_engine.scene.geometry import Geometry
from hybrid_engine.scene.data import Lights, MaterialTable, SceneData, Sky
from hybrid_engine.scene.settings import RenderSettings
from hybrid_engine.frame.viewport import RegionInput, plan_frame
from hybrid_engine.frame.views import (
    ViewportError,
    ViewportView,
    border_rect,
    camera_frame_rect,
    clip_range,
    crop_projection,
    render_size,
)
from scenes_analytic import box, quad

# Blender stores region and camera matrices as float32.
FLOAT32_MATRIX_RTOL = 1e-5
FLOAT32_MATRIX_ATOL = 1e-6
# Rasterizing the same triangles with projections that differ by float rounding can flip
# pixels whose centre lies exactly on an edge; allow this fraction of differing pixels.
EDGE_PIXEL_FRACTION = 0.02
# Colour difference that counts a pixel as different (the images are otherwise bit-equal).
PIXEL_DIFFERENCE = 1e-4

EYE = (4.0, -5.0, 3.0)
TARGET = (0.0, 0.0, 0.5)


def _scene() -> SceneData:
    """A lit coloured box on a floor: enough structure that a wrong matrix shows."""
    floor, cube = quad((0, 0, 0), (4, 0, 0), (0, 4, 0)), box((-1, -1, 0), (1, 1, 1.5))
    geometry = Geometry.from_objects([(floor, None, 1), (cube, None, 2)], ["floor", "box"])
    materials = MaterialTable.from_rows([dict(name="fallback"), dict(name="floor", base_color=(0.8, 0.8, 0.8)),
                                         dict(name="box", base_color=(0.9, 0.2, 0.1))])
    lights = Lights.from_rows([dict(kind="SUN", direction=(-0.3, 0.2, -1.0), color=(3, 3, 3))])
    return SceneData(geometry, materials, lights, Sky(color=(0.1, 0.2, 0.4)))


# Screen-space ambient occlusion would see only a cropped view's own depths: off here.
RASTER = RenderSettings(mode="RASTER", shadow_resolution=256, ao_distance=0.0)


def _differing_fraction(a: np.ndarray, b: np.ndarray) -> float:
    return float((np.abs(a - b).max(axis=-1) > PIXEL_DIFFERENCE).mean())


@pytest.fixture(scope="module")
def renderer(gl):
    from hybrid_engine.frame.renderer import Renderer

    r = Renderer(gl)
    yield r
    r.release()


# ---------------------------------------------------------------------------------------
# Matrices
# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("projection", ["PERSP", "ORTHO"])
def test_view_from_a_cameras_matrices_reproduces_the_camera(projection):
    """A view built from a camera's (view, projection) pair is that camera: same matrices,
    eye, forward axis, projection kind and clip range."""
    camera = Camera(matrix_world=look_at(EYE, TARGET), width=40, height=24, projection=projection,
                    lens=35.0, shift_x=0.1, clip_start=0.2, clip_end=60.0, ortho_scale=7.0)
    view = ViewportView.from_matrices(camera.view_matrix(), camera.projection_matrix(), 40, 24)
    assert isinstance(view, Camera)  # Renderer.render takes a Camera
    assert view.projection == projection
    np.testing.assert_allclose(view.view_projection(), camera.view_projection(), atol=1e-9)
    np.testing.assert_allclose(view.position, camera.position, atol=1e-9)
    np.testing.assert_allclose(view.forward, camera.forward, atol=1e-9)
    assert view.clip_start == pytest.approx(0.2) and view.clip_end == pytest.approx(60.0)
    np.testing.assert_allclose(view.viewplane(), camera.viewplane(), rtol=1e-9, atol=1e-12)


def test_orthographic_viewport_keeps_blenders_negative_near_plane():
    """Blender's orthographic viewport clips from -clip_end/2 to +clip_end/2; that range is
    read back, not rejected as a camera would reject it."""
    near, far = -50.0, 50.0
    p = np.eye(4)
    p[2, 2], p[2, 3] = -2 / (far - near), -(far + near) / (far - near)
    assert clip_range(p) == pytest.approx((near, far))
    view = ViewportView.from_matrices(np.eye(4), p, 10, 10)
    assert view.projection == "ORTHO" and view.clip_start == pytest.approx(near)


@pytest.mark.parametrize("bad", [
    dict(width=0, height=10),
    dict(window=np.zeros((4, 4))),
    dict(view=np.full((4, 4), np.nan)),
    dict(window=np.eye(3)),
])
def test_unusable_region_data_is_a_clear_error(bad):
    with pytest.raises(ViewportError):
        ViewportView.from_matrices(bad.get("view", np.eye(4)), bad.get("window", np.eye(4)),
                                   bad.get("width", 10), bad.get("height", 10))


@pytest.mark.parametrize("projection", ["PERSP", "ORTHO"])
def test_view_from_matrices_renders_the_image_of_the_camera(renderer, projection):
    """The renderer sees no difference between a core Camera and the view made of its matrices."""
    camera = Camera(matrix_world=look_at(EYE, TARGET), width=32, height=20, projection=projection,
                    ortho_scale=8.0)
    view = ViewportView.from_matrices(camera.view_matrix(), camera.projection_matrix(), 32, 20)
    scene = _scene()
    expected = renderer.render(scene, camera, RASTER, timing=False).image
    image = renderer.render(scene, view, RASTER, timing=False).image
    assert expected[..., :3].std() > 0.01  # the scene is visible, not a flat colour
    np.testing.assert_array_equal(image, expected)


def test_a_cropped_view_renders_that_part_of_the_image(renderer):
    """Cropping the projection to a pixel rectangle (the render border) renders exactly that
    rectangle of the full image."""
    camera = Camera(matrix_world=look_at(EYE, TARGET), width=40, height=30)
    view = ViewportView.from_matrices(camera.view_matrix(), camera.projection_matrix(), 40, 30)
    rect = (8, 5, 30, 21)
    scene = _scene()
    full = renderer.render(scene, view, RASTER, timing=False).image
    part = renderer.render(scene, view.cropped(rect), RASTER, timing=False).image
    assert part.shape == (16, 22, 4)
    assert _differing_fraction(part, full[5:21, 8:30]) < EDGE_PIXEL_FRACTION
    with pytest.raises(ViewportError):
        view.cropped((0, 0, 41, 10))


def test_crop_projection_maps_the_rectangle_onto_ndc():
    p = Camera(matrix_world=look_at(EYE, TARGET), width=100, height=50).projection_matrix()
    cropped = crop_projection(p, (25, 10, 75, 30), 100, 50)
    point = np.array([0.3, -0.2, -5.0, 1.0])
    full_ndc = (p @ point)[:2] / (p @ point)[3]
    crop_ndc = (cropped @ point)[:2] / (cropped @ point)[3]
    pixel = (full_ndc + 1) / 2 * [100, 50]
    np.testing.assert_allclose((crop_ndc + 1) / 2 * [50, 20], pixel - [25, 10], atol=1e-9)


def test_a_crop_knows_where_its_first_pixel_lies_in_the_whole_frame():
    """What the screen keys (the traced light's interleaved first directions) follows the
    whole frame's pixels: a render region, a crop of a crop, a sub-pixel sample (its pixel
    the nearest one) and a scaled view each carry their first pixel's place in it."""
    from hybrid_engine.frame.views import cropped_camera, region_camera
    from hybrid_engine.scene.camera import CameraError

    camera = Camera(matrix_world=look_at(EYE, TARGET), width=100, height=50)
    assert camera.pixel_origin == (0, 0)
    region = region_camera(camera, (25, 10, 75, 30))
    assert region.pixel_origin == (25, 10)
    assert region_camera(region, (5, 2, 20, 12)).pixel_origin == (30, 12)
    assert cropped_camera(region, (0.6, -0.3, 50.6, 19.7), 50, 20).pixel_origin == (26, 10)
    view = ViewportView.from_matrices(camera.view_matrix(), camera.projection_matrix(), 100, 50)
    assert view.cropped((8, 6, 40, 30)).pixel_origin == (8, 6)
    assert view.cropped((8, 6, 40, 30)).resized(16, 12).pixel_origin == (4, 3)
    with pytest.raises(CameraError, match="pixel origin"):
        Camera(pixel_origin=(1.5, 0))


def test_render_size_applies_the_viewport_scale():
    assert render_size(800, 600, 1.0) == (800, 600)
    assert render_size(800, 600, 0.25) == (200, 150)
    assert render_size(3, 3, 0.1) == (1, 1)  # never empty
    with pytest.raises(ViewportError):
        render_size(10, 10, 0.0)


def test_plan_frame_scales_and_places_the_render_border():
    """Camera view with a render border: the view is cropped to the border inside the
    camera frame and scaled; elsewhere the whole region is rendered."""
    camera = Camera(matrix_world=look_at(EYE, TARGET), width=50, height=25)
    # The region shows the camera frame at half size (a zoomed-out camera view): lens / 2.
    zoomed = Camera(matrix_world=camera.matrix_world, width=100, height=50, lens=camera.lens / 2)
    region = RegionInput(zoomed.view_matrix(), zoomed.projection_matrix(), 100, 50, "CAMERA", camera,
                         ((0.0, 0.0), (0.5, 1.0)))
    plan = plan_frame(region, 0.5)
    assert plan.rect == (25, 13, 50, 38)  # left half of the frame (25..75 x 12.5..37.5), halves rounded up
    assert (plan.view.width, plan.view.height) == (12, 12)  # 25 x 25 pixels at half scale
    whole = plan_frame(RegionInput(zoomed.view_matrix(), zoomed.projection_matrix(), 100, 50), 1.0)
    assert whole.rect == (0, 0, 100, 50) and whole.view.width == 100
    outside = RegionInput(zoomed.view_matrix(), zoomed.projection_matrix(), 100, 50, "CAMERA",
                          Camera(matrix_world=camera.matrix_world, width=50, height=25, shift_x=3.0),
                          ((0.0, 0.0), (1.0, 1.0)))
    assert plan_frame(outside, 1.0).view is None


def test_border_rect_clips_to_the_region():
    assert border_rect((-10, -10, 110, 60), (0, 0), (1, 1), 100, 50) == (0, 0, 100, 50)
    assert border_rect((10, 10, 90, 40), (0.25, 0.5), (0.75, 1.0), 100, 50) == (30, 25, 70, 40)
    assert border_rect((200, 10, 300, 40), (0, 0), (1, 1), 100, 50) is None


# ---------------------------------------------------------------------------------------
# Blender's own region math as the oracle
# ---------------------------------------------------------------------------------------
def _blender_camera(bpy, projection, lens=50.0, shift=(0.0, 0.0), ortho_scale=6.0):
    data = bpy.data.cameras.new("view")
    data.type = projection
    data.lens, data.ortho_scale = lens, ortho_scale
    data.shift_x, data.shift_y = shift
    data.clip_start, data.clip_end = 0.1, 100.0
    obj = bpy.data.objects.new("view", data)
    bpy.context.scene.collection.objects.link(obj)
    obj.matrix_world = [list(row) for row in look_at(EYE, TARGET).T]  # mathutils takes columns
    return obj


def _zoom_factor(camzoom: float) -> float:
    """Blender's BKE_screen_view3d_zoom_to_fac: camera-view zoom of RegionView3D.view_camera_zoom."""
    return (math.sqrt(2.0) + camzoom / 50.0) ** 2 / 4.0


@pytest.mark.parametrize("projection", ["PERSP", "ORTHO"])
def test_region_matrices_from_blender_equal_the_core_cameras(addon, projection):
    """Perspective and orthographic window matrices as Blender computes them
    (Object.calc_matrix_camera, the code RegionView3D uses) read back into the same
    projection as the core Camera with the same parameters."""
    import bpy

    obj = _blender_camera(bpy, projection, lens=28.0, shift=(0.05, -0.1), ortho_scale=9.0)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    window = np.array(obj.calc_matrix_camera(depsgraph, x=64, y=40))
    view_matrix = np.array(obj.matrix_world.inverted())
    view = ViewportView.from_matrices(view_matrix, window, 64, 40)
    core = Camera(matrix_world=np.array(obj.matrix_world), width=64, height=40, projection=projection,
                  lens=28.0, shift_x=0.05, shift_y=-0.1, clip_start=0.1, clip_end=100.0, ortho_scale=9.0)
    assert view.projection == projection
    np.testing.assert_allclose(view.projection_matrix(), core.projection_matrix(),
                               rtol=FLOAT32_MATRIX_RTOL, atol=FLOAT32_MATRIX_ATOL)
    np.testing.assert_allclose(view.view_matrix(), core.view_matrix(), rtol=FLOAT32_MATRIX_RTOL, atol=1e-5)
    assert (view.clip_start, view.clip_end) == pytest.approx((0.1, 100.0), rel=1e-4)


def test_camera_view_with_zoom_and_pan_renders_the_camera_frame_in_place(addon, renderer):
    """Camera view: Blender's window matrix is the camera's for the region size with the view
    plane scaled by the zoom (BKE_camera_params_from_view3d: zoom = 1.25 / zoom factor of
    ``view_camera_zoom``, pan as an offset of 2·camdx·factor region widths). The view built
    from it locates the camera frame where Blender draws it, and renders inside that frame
    the image of the scene camera itself."""
    import bpy

    zoom = 2.4  # the frame is 1/2.4 of the region: 40 of 96 pixels, pixel-aligned
    factor = 1.25 / zoom
    camzoom = 50.0 * (2.0 * math.sqrt(factor) - math.sqrt(2.0))
    assert _zoom_factor(camzoom) == pytest.approx(factor)
    camdx = 0.08  # pan: the frame moves by 2·camdx·factor·96 = 8 pixels
    region_w, region_h, lens = 96, 48, 50.0
    # Blender's viewplane for the region (pixsize *= zoom, dx = winx * 2 * camdx * factor) as a
    # camera at region size: lens / zoom and a shift of 2·camdx·factor (horizontal fit).
    region_cam = _blender_camera(bpy, "PERSP", lens=lens / zoom, shift=(2 * camdx * factor, 0.0))
    depsgraph = bpy.context.evaluated_depsgraph_get()
    window = np.array(region_cam.calc_matrix_camera(depsgraph, x=region_w, y=region_h))
    view = ViewportView.from_matrices(np.array(region_cam.matrix_world.inverted()), window, region_w, region_h)

    scene_camera = Camera(matrix_world=np.array(region_cam.matrix_world), width=40, height=20, lens=lens)
    frame = camera_frame_rect(view, scene_camera)
    # Independent expectation: 40x20 pixels centred on the region centre moved by the pan.
    centre_x = region_w / 2 - 2 * camdx * factor * region_w
    np.testing.assert_allclose(frame, (centre_x - 20, 14, centre_x + 20, 34), atol=1e-3)

    scene = _scene()
    rect = border_rect(frame, (0, 0), (1, 1), region_w, region_h)
    framed = renderer.render(scene, view.cropped(rect), RASTER, timing=False).image
    direct = renderer.render(scene, scene_camera, RASTER, timing=False).image
    assert framed.shape == direct.shape and framed[..., :3].std() > 0.01
    assert _differing_fraction(framed, direct) < EDGE_PIXEL_FRACTION
