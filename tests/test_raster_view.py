# SPDX-License-Identifier: GPL-3.0-or-later
"""The camera uniforms of a raster pass (hybrid_engine/scene/raster_view.py): the pixel on the
view's axis that random.glsl's position keys are sized by is the whole view's in every crop
of it (a render region, a sub-pixel sample)."""
from __future__ import annotations

import pytest

from hybrid_engine import Camera
from hybrid_engine.frame.antialias import jittered_camera
from hybrid_engine.frame.views import region_camera
from hybrid_engine.scene.camera import look_at
from hybrid_engine.scene.raster_view import RasterView, axis_pixel


def _pixel(camera: Camera) -> tuple[float, float]:
    view = RasterView.from_camera(camera)
    return axis_pixel(view.view_proj, view.height, view.orthographic)


@pytest.mark.parametrize("projection", ["PERSP", "ORTHO"])
def test_every_crop_of_a_view_has_the_whole_views_pixel(projection):
    camera = Camera(matrix_world=look_at((0.5, -5.0, 2.5), (0.0, 0.0, 0.5)), width=96, height=64,
                    projection=projection, ortho_scale=6.0)
    whole = _pixel(camera)
    # An off-centre region (its centre some 15 degrees off the axis) and a sub-pixel sample.
    for crop in (region_camera(camera, (60, 40, 96, 64)), region_camera(camera, (0, 0, 17, 9)),
                 jittered_camera(camera, 0.37, -0.21)):
        assert _pixel(crop) == pytest.approx(whole, rel=1e-9, abs=1e-15)
    if projection == "PERSP":
        # Blender's horizontal fit: the sensor's 36 mm over the 96 pixels at 50 mm.
        assert whole[0] == 0.0 and whole[1] == pytest.approx(36.0 / 50.0 / 96, rel=1e-6)
    else:
        assert whole[1] == 0.0 and whole[0] == pytest.approx(6.0 / 96, rel=1e-6)
