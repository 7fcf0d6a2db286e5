# SPDX-License-Identifier: GPL-3.0-or-later
"""The primary G-buffer pass (passes/gbuffer/gbuffer.py) in both shapes of the ``vertices``
kernel: drawn from the instance transform's world-space rows ("cpu") or instanced and
indexed from object-space meshes ("gpu", view_cull/instanced_draw.py). The two must write
the same G-buffer bit for bit: every target, on shared, multi-material, mirrored and flat
instances and on the Chess scene."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine import Camera, Geometry, SceneData
from hybrid_engine.gpu import variants
from hybrid_engine.passes.gbuffer.gbuffer import GBufferPass
from hybrid_engine.passes.scene_upload.scene_buffers import GPUScene
from hybrid_engine.passes.view_cull import draw
from hybrid_engine.scene.geometry import InstancedGeometry
from hybrid_engine.scene.meshes import Instances, ObjectMesh
from hybrid_engine.scene.raster_view import RasterView
from scenes_analytic import quad
from scenes_instanced import camera, instanced_scene, materials, placed, sphere_mesh

TARGETS = ("depth", "normal_material", "albedo", "emission_scale", "surface", "row")


@pytest.fixture
def raster(ctx):
    """A GPUScene and a GBufferPass of their own; the override is reset afterwards."""
    gpu, gbuffer = GPUScene(ctx), GBufferPass(ctx)
    yield gpu, gbuffer
    variants.set_override(None)
    gbuffer.release()
    gpu.release()


def render(gpu: GPUScene, gbuffer: GBufferPass, scene: SceneData, cam: Camera, family: str):
    """The primary G-buffer of ``scene`` drawn by the ``vertices`` kernel's ``family``: each
    target's bits, and the triangles submitted."""
    variants.set_override(f"vertices={family}")
    uploaded, _ = gpu.upload(scene)
    gpu.transform()
    targets, submitted = gbuffer.render_primary(gpu, uploaded, RasterView.from_camera(cam))
    return {name: targets.read(name).view(np.uint32).copy() for name in TARGETS}, submitted


def assert_same_gbuffer(rows: dict, instanced: dict) -> None:
    # The row target is not cleared: only pixels that show a surface hold a row.
    covered = rows["depth"][..., 0] != np.float32(1.0).view(np.uint32)
    for name in TARGETS:
        differ = (rows[name] != instanced[name]).any(axis=-1) & (covered if name == "row" else True)
        assert not differ.any(), f"{name}: {int(differ.sum())} pixels differ, first at {np.argwhere(differ)[:3].tolist()}"


@pytest.mark.parametrize("culled_lists", [False, True], ids=["object_lists", "culled_lists"])
def test_instanced_indexed_draws_write_the_rows_gbuffer_bit_for_bit(raster, monkeypatch, culled_lists):
    """Shared meshes, two material slots per mesh mapped per instance, mirrored instances
    (uniform and not), smooth normals and UVs: every target equals the rows' draw, whether
    the rows are drawn from object lists or from the per-triangle culled lists."""
    if culled_lists:
        monkeypatch.setattr(draw, "CULL_MIN_TRIANGLES", 0)
    gpu, gbuffer = raster
    scene, cam = instanced_scene(), camera()
    rows, rows_submitted = render(gpu, gbuffer, scene, cam, "cpu")
    assert (gbuffer.drawer.culled["primary"][0] is not None) == culled_lists
    instanced, submitted = render(gpu, gbuffer, scene, cam, "gpu")
    assert submitted == rows_submitted
    covered = rows["depth"][..., 0] != np.float32(1.0).view(np.uint32)
    materials_seen = {abs(int(m)) for m in rows["normal_material"][..., 3].view(np.float32)[covered]}
    assert covered.mean() > 0.5 and {2, 3, 4, 5, 6} <= materials_seen  # every slot of every instance kind
    assert (rows["normal_material"][..., 3].view(np.float32) < 0).any()  # back faces of the open grids
    assert_same_gbuffer(rows, instanced)
    stats = gbuffer.last_instanced
    assert stats.instanced == 6 and stats.from_rows == 0
    assert stats.vertices < 0.6 * 3 * stats.triangles  # shared corners shaded once


def test_the_chess_frame_is_the_same_instanced_as_from_the_rows(raster):
    """The Chess scene (instances of shared piece meshes, the nine-material board, closed
    pieces with back faces culled), its default soup draw (per-triangle culled lists)."""
    from benchmarks.scenes.chess import build_chess

    gpu, gbuffer = raster
    scene, cam = build_chess(0.05, 3, 320, 180)
    rows, rows_submitted = render(gpu, gbuffer, scene, cam, "cpu")
    assert gbuffer.drawer.culled["primary"][0] is not None
    instanced, submitted = render(gpu, gbuffer, scene, cam, "gpu")
    assert submitted == rows_submitted
    assert_same_gbuffer(rows, instanced)
    stats = gbuffer.last_instanced
    assert stats.from_rows == 0 and stats.vertices < 3 * stats.triangles


def test_flat_and_non_finite_objects_are_drawn_from_the_rows_in_their_place(raster):
    """A flat Geometry's objects share no vertex (a mesh of its own rows each) and a mesh
    with a non-finite vertex needs the transform's collapse: both are drawn from the rows,
    between the indexed instances, and the G-buffer is still the rows' one."""
    gpu, gbuffer = raster
    scene = instanced_scene()
    instances = scene.geometry.instances
    broken = sphere_mesh()
    positions = broken.positions.copy()
    positions[5] = np.nan
    broken = ObjectMesh(positions=positions, corner_vertices=broken.corner_vertices, normals=broken.normals,
                        corner_normals=broken.corner_normals, slots=broken.slots, uvs=broken.uvs)
    flat = Geometry.from_objects([(quad((0, 0, 0), (0.6, 0, 0), (0, 0, 0.6)), None, 3)]).as_instances()
    soup_mesh = flat.instances.meshes[0]
    mixed = Instances(meshes=[*instances.meshes, broken, soup_mesh], mesh=np.array([0, 2, 1, 3, 0, 1]),
                      matrices=np.concatenate([instances.matrices[:2], [placed(np.eye(3), (-1.2, 1.5, 1.2))],
                                               instances.matrices[4:5], [placed(np.eye(3), (1.5, -1.0, 1.0))],
                                               instances.matrices[5:]]).astype(np.float32),
                      slot_materials=[np.int32([1, 2]), np.int32([3, 4]), np.int32([0, 5]), np.int32([0, 1, 2, 3]),
                                      np.int32([2, 4]), np.int32([5, 0])])
    scene = SceneData(geometry=InstancedGeometry(mixed), materials=materials())
    cam = camera()
    rows, _ = render(gpu, gbuffer, scene, cam, "cpu")
    instanced, _ = render(gpu, gbuffer, scene, cam, "gpu")
    assert_same_gbuffer(rows, instanced)
    stats = gbuffer.last_instanced
    assert (stats.instanced, stats.from_rows) == (4, 2)


def test_a_deformed_mesh_is_resent_into_place_and_drawn_deformed(raster):
    gpu, gbuffer = raster
    scene, cam = instanced_scene(), camera()
    render(gpu, gbuffer, scene, cam, "gpu")
    instances = scene.geometry.instances
    sphere = instances.meshes[0]
    wobble = sphere.positions * (1.0 + 0.15 * np.sin(5 * sphere.positions[:, 2:3])).astype(np.float32)
    instances.meshes[0] = sphere.deformed(wobble, sphere.normals)
    scene.geometry.refresh()
    instanced, _ = render(gpu, gbuffer, scene, cam, "gpu")
    assert gpu.raster_meshes.meshes_sent == 1  # the deformed sphere only, in place
    rows, _ = render(gpu, gbuffer, scene, cam, "cpu")
    assert_same_gbuffer(rows, instanced)


@pytest.mark.parametrize(("renderer", "override", "instanced"), [
    ("llvmpipe (LLVM 15.0.7, 256 bits)", None, False),
    ("NVIDIA GeForce RTX 4090/PCIe/SSE2", None, True),
    ("llvmpipe (LLVM 15.0.7, 256 bits)", "vertices=gpu", True),
    ("NVIDIA GeForce RTX 4090/PCIe/SSE2", "cpu", False),
])
def test_the_draw_follows_the_renderer_string_and_the_override(raster, monkeypatch, renderer, override,
                                                               instanced):
    """The renderer string picks the shape (software: the rows), the override wins."""
    from hybrid_engine.gpu import gl_context

    monkeypatch.setattr(gl_context, "renderer_name", lambda: renderer)
    variants.set_override(override)
    gpu, gbuffer = raster
    scene = instanced_scene()
    uploaded, _ = gpu.upload(scene)
    gpu.transform()
    gbuffer.render_primary(gpu, uploaded, RasterView.from_camera(camera()))
    assert (gbuffer.last_instanced is not None) == instanced


def test_whole_frames_are_the_same_in_both_shapes(ctx):
    """RASTER (shadow maps, G-buffer, shading) and HYBRID (the tracer reading the G-buffer)
    frames of the Chess scene are the same images with the vertices kernel in either shape."""
    from benchmarks.scenes.chess import CHESS_CUBE_FAR, build_chess
    from hybrid_engine import RenderSettings
    from hybrid_engine.frame.renderer import Renderer

    scene, cam = build_chess(0.1, 3, 160, 90)
    images = {}
    for family in ("cpu", "gpu"):
        variants.set_override(f"vertices={family}")
        renderer = Renderer(ctx)
        try:
            for mode in ("RASTER", "HYBRID"):
                settings = RenderSettings(mode=mode, cube_far=CHESS_CUBE_FAR, near_size=3.5)
                images[family, mode] = renderer.render(scene, cam, settings).image.view(np.uint32).copy()
            assert bool(renderer.gbuffer.drawer.instanced) == (family == "gpu")
        finally:
            variants.set_override(None)
            renderer.release()
    for mode in ("RASTER", "HYBRID"):
        differ = (images["cpu", mode] != images["gpu", mode]).any(axis=-1)
        assert not differ.any(), f"{mode}: {int(differ.sum())} pixels differ"
