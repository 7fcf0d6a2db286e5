# SPDX-License-Identifier: GPL-3.0-or-later
"""The instances' moves between frames (hybrid_engine/passes/surface_motion/): the host finds
the instances whose matrix changed and their world-to-world move; the GPU marks the primary
pixels that show them, and no pixel where something else stands in front."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine import Camera, Lights, MaterialTable, RenderSettings, SceneData, Sky
from hybrid_engine.frame.film import FrameOutputs
from hybrid_engine.passes.surface_motion.surface_motion import InstanceMoves, row_ranges
from hybrid_engine.scene.camera import look_at
from hybrid_engine.scene.geometry import InstancedGeometry
from hybrid_engine.scene.meshes import Instances
from scenes_analytic import box, quad
from scenes_instanced import deformed, flat_mesh, placed, rotation_z


def geometry(matrices, meshes=(0, 1, 1, 1)) -> InstancedGeometry:
    """A floor, then boxes: instance k uses mesh ``meshes[k]`` (0 the floor, 1 the box) under
    ``matrices[k]``."""
    floor, block = flat_mesh(quad((0, 0, 0), (20, 0, 0), (0, 20, 0))), flat_mesh(box((-0.5, -0.5, 0), (0.5, 0.5, 1)))
    return InstancedGeometry(Instances(meshes=[floor, block], mesh=np.array(meshes),
                                       matrices=np.array(matrices, np.float32),
                                       slot_materials=[np.int32([0])] * len(meshes)))


def moved_between(gl, before: SceneData, after: SceneData, camera: Camera) -> tuple[np.ndarray, np.ndarray]:
    """The entry + 1 the surface-motion image gives each pixel of ``after`` (0: not moved)
    when it follows ``before``, and the world row the G-buffer shows there (denoised RASTER
    frames, the viewport's shape)."""
    from hybrid_engine.frame.renderer import Renderer

    renderer = Renderer(gl)
    settings = RenderSettings(mode="RASTER", shadow_resolution=256)
    try:
        renderer.render(before, camera, settings, denoise=True)
        renderer.render(after, camera, settings, denoise=True)
        return renderer.surface_motion.read()[..., 3], renderer.gbuffer.primary.read("row")[..., 0]
    finally:
        renderer.release()


def test_only_the_instances_whose_matrix_changed_move_by_previous_times_current_inverse():
    moves = InstanceMoves()
    still, left = np.eye(4), placed(np.eye(3), (-2, 0, 0))
    first = [still, left, placed(np.eye(3), (2, 0, 0))]
    geometry_of = lambda matrices: geometry(matrices, meshes=(0, 1, 1))  # noqa: E731
    assert len(moves.moves(geometry_of(first))[0]) == 0  # a first frame has nothing to move from
    assert len(moves.moves(geometry_of(first))[0]) == 0
    turned = placed(rotation_z(30) * 1.5, (-1, 1, 0))
    moved, matrices = moves.moves(geometry_of([still, turned, first[2]]))
    assert moved.tolist() == [1]
    point = np.array([0.3, -0.2, 0.7, 1.0])  # a point of the box's mesh
    np.testing.assert_allclose(matrices[0] @ (turned @ point), left @ point, atol=1e-5)


def test_a_changed_instance_table_moves_nothing():
    moves = InstanceMoves()
    moves.moves(geometry([np.eye(4), np.eye(4), np.eye(4)], meshes=(0, 1, 1)))
    assert len(moves.moves(geometry([np.eye(4), placed(np.eye(3), (1, 0, 0))], meshes=(0, 1)))[0]) == 0
    assert len(moves.moves(geometry([np.eye(4), placed(np.eye(3), (2, 0, 0))], meshes=(1, 1)))[0]) == 0


def test_the_moved_instances_rows_are_listed_by_first_row_with_their_entries():
    object_ranges = np.array([[0, 2], [2, 12], [14, 12], [26, 12]])
    table = row_ranges(object_ranges, np.array([3, 1, 2]))
    assert table.tolist() == [[2, 14, 1, -1], [14, 26, 2, -1], [26, 38, 0, -1]]
    deformed_rows = row_ranges(object_ranges, np.array([1, 3]), np.array([0, 12]))
    assert deformed_rows.tolist() == [[2, 14, 0, 0], [26, 38, 1, 12]]


@pytest.mark.parametrize("vertices", ["cpu", "gpu"])
def test_the_pixels_of_a_moved_instance_get_its_entry_and_none_where_a_still_one_hides_it(gl, monkeypatch, vertices):
    monkeypatch.setenv("HYBRID_RT_KERNELS", f"vertices={vertices}")
    camera = Camera(matrix_world=look_at((0.0, -8.0, 3.0), (0, 0, 0.5)), width=96, height=72)
    materials = MaterialTable.from_rows([dict(base_color=(0.8, 0.8, 0.8))])
    pillar = placed(np.diag([0.6, 0.2, 3.0]), (0.0, -2.0, 0.0))  # still, before the box's middle

    def scene(x: float) -> SceneData:
        # A second box, after the still pillar in the table: the moved rows are two draws.
        return SceneData(geometry([np.eye(4), placed(np.eye(3), (x, 0, 0)), pillar, placed(np.eye(3), (-2 - x, 0, 0))]),
                         materials, Lights.empty(), Sky(color=(1.0, 1.0, 1.0)))

    marked, _ = moved_between(gl, scene(0.0), scene(0.2), camera)
    origins, dirs = camera.pixel_rays()
    # The box at x = 0.2 spans [-0.3, 0.7] x [-0.5, 0.5] x [0, 1]; the pillar [-0.3, 0.3] x
    # [-2.1, -1.9] x [0, 3] stands between it and the camera over part of it.
    t_front = (-0.5 - origins[..., 1]) / dirs[..., 1]
    front = origins + dirs * t_front[..., None]
    on_box_face = (front[..., 0] > -0.25) & (front[..., 0] < 0.65) & (front[..., 2] > 0.05) & (front[..., 2] < 0.95)
    t_pillar = (-2.1 - origins[..., 1]) / dirs[..., 1]
    at_pillar = origins + dirs * t_pillar[..., None]
    behind_pillar = (np.abs(at_pillar[..., 0]) < 0.27) & (at_pillar[..., 2] > 0.03) & (at_pillar[..., 2] < 2.97)
    beside_pillar = np.abs(at_pillar[..., 0]) > 0.33
    visible = on_box_face & beside_pillar
    hidden = on_box_face & behind_pillar
    assert visible.sum() > 20 and hidden.sum() > 20
    assert (marked[visible] == 1.0).all()
    second = (front[..., 0] > -2.65) & (front[..., 0] < -1.75) & (front[..., 2] > 0.05) & (front[..., 2] < 0.95)
    assert second.sum() > 20 and (marked[second] == 2.0).all()
    assert (marked[hidden] == 0.0).all() and (marked[behind_pillar] == 0.0).all()


@pytest.mark.parametrize("vertices", ["cpu", "gpu"])
def test_a_moved_sheet_on_a_still_floor_marks_the_pixels_that_show_it_and_none_that_show_the_floor(
        gl, monkeypatch, vertices):
    # A sheet lying on the floor, tilted by a ten-thousandth of a radian about its middle: it
    # shows on one half and dips under the floor on the other, so close that no depth test
    # with a tolerance tells the two apart there. A pixel is the moved sheet's by the world
    # row the G-buffer shows (the floor is rows 0-1, the sheet 2-3), not by its depth.
    monkeypatch.setenv("HYBRID_RT_KERNELS", f"vertices={vertices}")
    camera = Camera(matrix_world=look_at((0.0, -6.0, 4.0), (0, 0, 0)), width=96, height=72)
    materials = MaterialTable.from_rows([dict(base_color=(0.8, 0.8, 0.8))])
    floor, sheet = flat_mesh(quad((0, 0, 0), (20, 0, 0), (0, 20, 0))), flat_mesh(quad((0, 0, 0), (1.5, 0, 0), (0, 1.5, 0)))
    tilt = 1e-4
    turned = np.array([[1, 0, 0], [0, np.cos(tilt), -np.sin(tilt)], [0, np.sin(tilt), np.cos(tilt)]])

    def scene(x: float) -> SceneData:
        instances = Instances(meshes=[floor, sheet], mesh=np.array([0, 1]),
                              matrices=np.array([np.eye(4), placed(turned, (x, 0, 0))], np.float32),
                              slot_materials=[np.int32([0])] * 2)
        return SceneData(InstancedGeometry(instances), materials, Lights.empty(), Sky(color=(1.0, 1.0, 1.0)))

    marked, rows = moved_between(gl, scene(0.0), scene(0.05), camera)
    origins, dirs = camera.pixel_rays()
    on_floor = origins + dirs * (-origins[..., 2] / dirs[..., 2])[..., None]
    inside = (np.abs(on_floor[..., 0] - 0.05) < 1.4) & (np.abs(on_floor[..., 1]) < 1.4)
    raised = inside & (on_floor[..., 1] > 0.1)
    shows_sheet = (rows == 2) | (rows == 3)
    assert raised.sum() > 200 and shows_sheet[raised].all()
    assert (inside & ~shows_sheet).sum() > 200  # the floor, a hair above the dipped half
    assert (marked[shows_sheet] == 1.0).all()
    assert (marked[~shows_sheet] == 0.0).all()


def test_a_deformed_meshs_pixels_get_the_points_and_normals_its_surface_had_last_frame(gl):
    from hybrid_engine.frame.renderer import Renderer

    # The box's mesh deforms (its vertices move and turn; its instance's matrix stays the
    # identity): the instance transform keeps its world rows of last frame, and each pixel
    # of the box gets the point of the surface there, and the rotation of its normal.
    camera = Camera(matrix_world=look_at((3.0, -6.0, 5.0), (0, 0, 0)), width=64, height=64)
    floor, block = flat_mesh(quad((0, 0, 0), (20, 0, 0), (0, 20, 0))), flat_mesh(box((-0.6, -0.6, 0), (0.6, 0.6, 0.8)))
    before, after = placed(np.eye(3), (-0.9, 0.0, 0.0)), placed(rotation_z(40), (0.9, 0.3, 0.0))

    def scene(matrix, version: int) -> SceneData:
        meshes = [floor, deformed(block, matrix, version)]
        instances = Instances(meshes=meshes, mesh=np.array([0, 1]), matrices=np.array([np.eye(4)] * 2, np.float32),
                              slot_materials=[np.int32([0])] * 2)
        return SceneData(InstancedGeometry(instances), MaterialTable.from_rows([dict(base_color=(0.8, 0.8, 0.8))]),
                         Lights.empty(), Sky(color=(1.0, 1.0, 1.0)))

    renderer = Renderer(gl)
    settings = RenderSettings(mode="RASTER", shadow_resolution=256)
    try:
        renderer.render(scene(before, 1), camera, settings, denoise=True)
        result = renderer.render(scene(after, 2), camera, settings, denoise=True,
                                 outputs=FrameOutputs(normal=True, depth=True))
        motion, turn = renderer.surface_motion.read(), renderer.surface_motion.read_turn()
    finally:
        renderer.release()
    on_box = motion[..., 3] == 1.0  # entry 0: the box (the floor did not move)
    assert on_box.sum() > 200 and not (motion[~on_box, 3] > 0).any()
    # Last frame's point: the current one taken back by the deformation.
    back = before @ np.linalg.inv(after)
    origins, dirs = camera.pixel_rays()
    forward = -np.asarray(camera.matrix_world)[:3, 2]
    position = origins + dirs * (result.data_passes["depth"] / (dirs @ forward))[..., None]
    expected = position @ back[:3, :3].T + back[:3, 3]
    np.testing.assert_allclose(motion[on_box, :3], expected[on_box], atol=2e-3)
    # The normal turned by -40 degrees about z.
    normal = result.data_passes["normal"][..., :3][on_box]
    q = turn[on_box]
    turned = normal + 2.0 * np.cross(q[:, :3], np.cross(q[:, :3], normal) + q[:, 3:] * normal)
    np.testing.assert_allclose(turned, normal @ rotation_z(-40).T, atol=2e-3)
