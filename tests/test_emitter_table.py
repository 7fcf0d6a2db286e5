# SPDX-License-Identifier: GPL-3.0-or-later
"""The emitter table (hybrid_engine/passes/emitters/emitter_table.py): which triangles emit,
each one's power from its world-space triangle on the GPU, and the CDF the lights are picked
by, in both shapes of the prefix scan."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine.gpu import dispatch as gpu_dispatch
from hybrid_engine.gpu.triangle_input import input_split
from hybrid_engine.passes.emitters.emitter_table import (
    EmitterTable, emissive_materials, emissive_rows, levels_for)
from hybrid_engine.passes.scene_upload.scene_buffers import GPUScene
from hybrid_engine.scene.data import MaterialTable, SceneData
from hybrid_engine.scene.geometry import InstancedGeometry
from hybrid_engine.scene.meshes import Instances
from hybrid_engine.scene.settings import RenderSettings
from scenes_instanced import camera, grid_mesh, placed, rotation_z, sphere_mesh

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
GREY, LAMP, DIM_RED, DARK = 0, 1, 2, 3


def materials(lamp=(4.0, 3.0, 2.0)) -> MaterialTable:
    return MaterialTable.from_rows([dict(name="grey"), dict(name="lamp", emission=lamp),
                                    dict(name="dim red", emission=(0.5, 0.0, 0.0)),
                                    dict(name="dark", emission=(0.0, 0.0, 0.0))])


def instanced_scene(cells: int = 6, grids: int = 3, table: MaterialTable | None = None) -> SceneData:
    """Spheres whose two slots are a lamp and grey, or grey and dim red; checkerboard grids
    whose second slot is missing (material 0, grey) or a lamp, scaled apart so their
    triangles' powers differ."""
    meshes = [sphere_mesh(), grid_mesh(cells)]
    rows = [(0, placed(np.eye(3), (0, 0, 3)), [LAMP, GREY]),
            (0, placed(np.diag([1, 2, 0.5]), (4, 0, 0)), [GREY, DIM_RED]),
            (1, placed(rotation_z(30) * 2.0, (0, 0, -1)), [GREY])]
    rows += [(1, placed(np.eye(3) * (1 + k), (0, 5 * k, 2)), [DARK, LAMP]) for k in range(grids)]
    instances = Instances(meshes=meshes, mesh=np.array([r[0] for r in rows]),
                          matrices=np.stack([r[1] for r in rows]), slot_materials=[np.array(r[2]) for r in rows])
    return SceneData(geometry=InstancedGeometry(instances), materials=table or materials())


def oracle(scene: SceneData) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The emissive rows, their world triangles and powers, on the host (world_arrays: the
    instance transform's arithmetic)."""
    world = scene.geometry.world_arrays()
    emission = scene.materials.emission[world["material_ids"]].astype(np.float64)
    rows = np.flatnonzero((emission @ LUMINANCE) > 0)
    tris = world["triangles"][rows].astype(np.float64)
    area = 0.5 * np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1)
    return rows, tris, area * (emission[rows] @ LUMINANCE)


@pytest.fixture
def upload(gl):
    made = []

    def run(scene: SceneData, table: EmitterTable, world: GPUScene | None = None) -> GPUScene:
        if world is None:
            world = GPUScene(gl)
            made.append(world)
        uploaded, delta = world.upload(scene)
        world.transform()
        table.update(uploaded, world, rows_unchanged=delta.unchanged)
        return world

    yield run
    for world in made:
        world.release()


def test_the_emissive_rows_are_the_triangles_whose_material_emits_as_the_transform_assigns_them():
    scene = instanced_scene()
    rows, _, _ = oracle(scene)
    assert 0 < len(rows) < scene.geometry.triangle_count
    assert np.array_equal(emissive_rows(scene.geometry, emissive_materials(scene.materials)), rows)
    # Material 0 emitting makes the triangles of missing slots emit too.
    glowing_grey = MaterialTable.from_rows([dict(name="grey", emission=(1, 1, 1)), dict(name="lamp")])
    world = scene.geometry.world_arrays()
    assert np.array_equal(emissive_rows(scene.geometry, emissive_materials(glowing_grey)),
                          np.flatnonzero(world["material_ids"] == 0))


@pytest.mark.parametrize("scan_family", ["cpu", "gpu"])
def test_each_emitter_s_power_is_its_world_area_times_luminance_and_the_cdf_scans_the_weights(
        gl, upload, scan_family):
    # Enough emitters for the "gpu" scan to take several blocks (2,048 values each).
    scene = instanced_scene(cells=26, grids=4)
    table = EmitterTable(gl, scan_family)
    try:
        upload(scene, table)
        rows, tris, power = oracle(scene)
        assert table.count == len(rows) > 2048
        got = table.read_table()
        assert np.array_equal(got["corner"][:, 3].view(np.int32), rows)
        np.testing.assert_allclose(got["corner"][:, :3], tris[:, 0], atol=1e-5)
        np.testing.assert_allclose(got["edge1"][:, :3], tris[:, 1] - tris[:, 0], atol=1e-5)
        np.testing.assert_allclose(got["edge2"][:, :3], tris[:, 2] - tris[:, 0], atol=1e-5)
        np.testing.assert_allclose(got["edge2"][:, 3], power, rtol=1e-5)
        cdf = table.read_cdf().astype(np.int64)
        weights = np.diff(cdf)
        assert cdf[0] == 0 and len(cdf) == table.count + 1
        expected = np.maximum(1, np.round(power / power.max() * levels_for(table.count)))
        assert np.abs(weights - expected).max() <= 1
        assert cdf[-1] < 2 ** 32
    finally:
        table.release()


def test_the_table_is_remade_only_for_what_changed_and_motion_moves_the_lights(gl, upload):
    scene = instanced_scene()
    table = EmitterTable(gl)
    try:
        world = upload(scene, table)
        assert table.stats.listed and table.stats.gpu_steps == 3
        first = table.read_table()
        # Nothing moved, the same emission: the table stands, no dispatch.
        upload(scene, table, world)
        assert not table.stats.listed and table.stats.gpu_steps == 0
        # A brighter lamp: the same list, new powers.
        brighter = SceneData(geometry=scene.geometry, materials=materials(lamp=(8.0, 6.0, 4.0)))
        upload(brighter, table, world)
        assert not table.stats.listed and table.stats.gpu_steps == 3
        np.testing.assert_allclose(table.read_table()["edge2"][:, 3], oracle(brighter)[2], rtol=1e-5)
        # A moved lamp: no new list, its triangles follow on the GPU.
        scene.geometry.instances.matrices[0] = placed(np.eye(3), (1.0, 2.0, 3.5))
        scene.geometry.refresh([0])
        upload(scene, table, world)
        assert not table.stats.listed and table.stats.gpu_steps == 3
        moved = table.read_table()
        _, tris, _ = oracle(scene)
        np.testing.assert_allclose(moved["corner"][:, :3], tris[:, 0], atol=1e-5)
        assert not np.allclose(moved["corner"][:, :3], first["corner"][:, :3])
        # The lamp switched off: a new list without the spheres' lamp slot.
        dimmer = SceneData(geometry=scene.geometry, materials=materials(lamp=(0.0, 0.0, 0.0)))
        upload(dimmer, table, world)
        assert table.stats.listed and table.count == len(oracle(dimmer)[0]) < len(first)
    finally:
        table.release()


def test_a_scene_without_emission_costs_no_list_and_no_dispatch(gl, upload):
    scene = instanced_scene(table=MaterialTable.from_rows([dict(name="grey"), dict(name="lamp")] * 2))
    table = EmitterTable(gl)
    try:
        upload(scene, table)
        assert table.count == 0 and not table.stats.listed and table.stats.gpu_steps == 0
        assert table.bindings().uniforms["u_emitter_count"] == 0
    finally:
        table.release()


def test_emitters_are_read_from_every_block_of_a_split_triangle_input(gl, upload):
    # A driver whose storage blocks hold 682 triangles of positions: the scene's 1,008
    # triangles are bound as two blocks (triangle_input.glsl), its lamps in both.
    scene = instanced_scene()
    table = EmitterTable(gl)
    try:
        with gpu_dispatch.forced_limits(max_block=24576):
            assert input_split(scene.geometry.triangle_count).blocks == 2
            upload(scene, table)
        rows, tris, power = oracle(scene)
        assert rows.min() < 682 <= rows.max()
        got = table.read_table()
        np.testing.assert_allclose(got["corner"][:, :3], tris[:, 0], atol=1e-5)
        np.testing.assert_allclose(got["edge2"][:, 3], power, rtol=1e-5)
    finally:
        table.release()


@pytest.mark.parametrize("mode", ["HYBRID", "FULL_BVH"])
def test_a_traced_frame_hands_its_passes_the_table_of_this_frame_s_emitters(renderer, mode):
    scene = instanced_scene()
    plan = [type(p).__name__ for p in renderer.passes(RenderSettings(mode=mode))]
    assert plan.index("EmitterTablePass") == plan.index("InstanceTransformPass") + 1
    assert "EmitterTablePass" not in [type(p).__name__ for p in renderer.passes(RenderSettings(mode="RASTER"))]
    result = renderer.render(scene, camera(40, 30), RenderSettings(mode=mode), timing=True)
    table = renderer.emitters.table
    rows, tris, _ = oracle(scene)
    assert table.count == len(rows)
    np.testing.assert_allclose(table.read_table()["corner"][:, :3], tris[:, 0], atol=1e-5)
    assert "emitters" not in result.passes  # timed with the transform's step
