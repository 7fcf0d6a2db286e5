# SPDX-License-Identifier: GPL-3.0-or-later
"""The shadow-map pass (hybrid_engine/passes/shadow_maps/shadow_depth.py): a point lamp's six
cube faces (and the other slots of a culled batch) drawn in one multi-draw equal one draw
per slot, bit for bit, and the faces kernel's variant picks which; a lamp's depth range
follows the scene's scale."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine import Geometry, Lights, MaterialTable, RenderSettings, SceneData, Sky
from hybrid_engine.gpu import variants
from hybrid_engine.passes.scene_upload.scene_buffers import GPUScene
from hybrid_engine.passes.shadow_maps.shadow_depth import ShadowDepthPass, shadow_views
from hybrid_engine.passes.view_cull import draw as draw_module
from hybrid_engine.passes.view_cull.draw import SceneDrawer
from hybrid_engine.passes.view_cull.view_cull import CulledDraws
from hybrid_engine.scene.bounds import SceneBounds
from hybrid_engine.scene.changes import GeometryDelta
from benchmarks.scenes.chess import build_chess
from scenes_analytic import box, quad


def shadow_layers_with_variant(gl, monkeypatch, family: str) -> tuple[bytes, int, dict]:
    """The static shadow layer of a Chess frame (a sun, its two cascades and a point lamp's
    six faces: nine slots, culled in batches of six) with the faces kernel forced to
    ``family``: the layer's bytes, the triangles submitted and the draws of each kind."""
    calls = {"draw": 0, "draw_all": 0}
    for name in calls:
        original = getattr(CulledDraws, name)

        def counted(self, *args, _name=name, _original=original):
            calls[_name] += 1
            return _original(self, *args)
        monkeypatch.setattr(CulledDraws, name, counted)
    scene, camera = build_chess(detail=0.02, frame=3, width=64, height=36)
    assert scene.geometry.triangle_count >= draw_module.CULL_MIN_TRIANGLES  # the culled path
    settings = RenderSettings(mode="RASTER", shadow_resolution=256, shadow_cascades=2)
    gpu, drawer = GPUScene(gl), SceneDrawer(gl)
    shadows = ShadowDepthPass(gl, drawer)
    variants.set_override(f"faces={family},vertices=cpu")  # the culled batches (not the instanced draws)
    try:
        gpu.upload(scene)
        gpu.transform()
        maps = shadows.render(gpu, scene, camera, settings, shadows.atlas, GeometryDelta.everything(0))
        layer = shadows.atlas.static.read()
    finally:
        variants.set_override(None)
        shadows.release()
        drawer.release()
        gpu.release()
    return layer, maps.submitted, dict(calls)


def test_shadow_slots_in_one_draw_per_batch_equal_one_draw_per_slot_bit_for_bit(gl, monkeypatch):
    per_slot, submitted_cpu, cpu_draws = shadow_layers_with_variant(gl, monkeypatch, "cpu")
    one_draw, submitted_gpu, gpu_draws = shadow_layers_with_variant(gl, monkeypatch, "gpu")
    assert cpu_draws["draw_all"] == 0 and cpu_draws["draw"] >= 9
    # Two layers (static, dynamic) of batches of at most six slots: 9 slots, 2 batches each.
    assert gpu_draws["draw"] == 0 and 2 <= gpu_draws["draw_all"] <= 4
    assert submitted_cpu == submitted_gpu > 0
    a, b = np.frombuffer(per_slot, np.uint8), np.frombuffer(one_draw, np.uint8)
    assert np.array_equal(a, b), f"{np.count_nonzero(a != b)} bytes differ"
    depth = np.frombuffer(one_draw, np.float32)
    assert 0.05 < (depth < 1.0).mean(), "the layer holds the scene's depths"


@pytest.mark.parametrize("family", ["cpu", "gpu"])
def test_the_shadow_pass_compiles_the_one_draw_program_only_for_the_gpu_variant(gl, family):
    drawer = SceneDrawer(gl)
    shadows = ShadowDepthPass(gl, drawer)
    variants.set_override(f"faces={family},vertices=cpu")  # the culled batches (not the instanced draws)
    try:
        program = shadows.faces_program()
    finally:
        variants.set_override(None)
        shadows.release()
        drawer.release()
    assert (program is not None) == (family == "gpu")


def shadow_layers_with_vertices(gl, family: str) -> tuple[tuple[np.ndarray, np.ndarray], int, dict]:
    """Both shadow layers of a Chess frame (a sun, its two cascades, a point lamp's six faces;
    the pieces that move in the dynamic layer) with the vertices kernel forced to ``family``:
    the layers, the triangles submitted and the instanced draws' statistics per layer."""
    scene, camera = build_chess(detail=0.02, frame=3, width=64, height=36)
    settings = RenderSettings(mode="RASTER", shadow_resolution=256, shadow_cascades=2)
    gpu, drawer = GPUScene(gl), SceneDrawer(gl)
    shadows = ShadowDepthPass(gl, drawer)
    variants.set_override(f"vertices={family}")
    try:
        uploaded, _ = gpu.upload(scene)
        gpu.transform()
        everything = GeometryDelta.everything(scene.geometry.triangle_count)
        dynamic = np.zeros(len(scene.geometry.object_ranges), bool)
        dynamic[-40:] = True  # some pieces moved: both layers are drawn
        delta = GeometryDelta(full=False, ranges=tuple((int(a), int(b)) for a, b in
                                                       scene.geometry.object_ranges[dynamic]),
                              changed_triangles=1, sequence=1)
        shadows.render(gpu, uploaded, camera, settings, shadows.atlas, everything)
        maps = shadows.render(gpu, uploaded, camera, settings, shadows.atlas, delta)
        layers = shadows.atlas.read_layers()
        layers = (layers[0].copy(), layers[1].copy())
    finally:
        variants.set_override(None)
        shadows.release()
        drawer.release()
        gpu.release()
    return layers, maps.submitted, dict(drawer.instanced)


def test_shadow_slots_drawn_instanced_and_indexed_equal_the_rows_bit_for_bit(gl):
    """The vertices kernel's "gpu" variant draws the shadow slots from object-space meshes
    (view_cull/instanced_draw.py): the same depths in every slot of both layers."""
    rows, submitted_rows, rows_stats = shadow_layers_with_vertices(gl, "cpu")
    indexed, submitted_indexed, stats = shadow_layers_with_vertices(gl, "gpu")
    assert rows_stats == {} and stats and all(s.instanced > 0 and s.from_rows == 0 for s in stats.values())
    assert submitted_rows == submitted_indexed > 0
    assert sum(s.vertices for s in stats.values()) < 3 * sum(s.triangles for s in stats.values())
    for layer_rows, layer_indexed in zip(rows, indexed):
        assert (layer_rows < 1).any()
        differ = layer_rows.view(np.uint32) != layer_indexed.view(np.uint32)
        assert not differ.any(), f"{int(differ.sum())} texels differ"


def test_shadow_slots_of_rotated_and_mirrored_instances_are_the_same_drawn_instanced(gl):
    """Instances under rotations, non-uniform scales and mirrors (scenes_instanced.py), a sun
    and a point lamp's six faces: the instanced, indexed depths equal the rows' bit for bit."""
    from hybrid_engine import Lights
    from scenes_instanced import camera, instanced_scene

    scene = instanced_scene()
    scene.lights = Lights.from_rows([dict(kind="SUN", direction=(0.3, 0.5, -1.0), color=(3.0, 3.0, 3.0)),
                                     dict(kind="POINT", position=(0.5, -1.5, 2.5), color=(50.0, 50.0, 50.0))])
    settings = RenderSettings(mode="RASTER", shadow_resolution=256)
    layers = {}
    for family in ("cpu", "gpu"):
        gpu, drawer = GPUScene(gl), SceneDrawer(gl)
        shadows = ShadowDepthPass(gl, drawer)
        variants.set_override(f"vertices={family}")
        try:
            uploaded, _ = gpu.upload(scene)
            gpu.transform()
            shadows.render(gpu, uploaded, camera(), settings, shadows.atlas,
                           GeometryDelta.everything(scene.geometry.triangle_count))
            layers[family] = shadows.atlas.read_layers()[0].copy()
            assert bool(drawer.instanced) == (family == "gpu")
        finally:
            variants.set_override(None)
            shadows.release()
            drawer.release()
            gpu.release()
    assert (layers["cpu"] < 1).mean() > 0.05
    differ = layers["cpu"].view(np.uint32) != layers["gpu"].view(np.uint32)
    assert not differ.any(), f"{int(differ.sum())} texels differ"


@pytest.mark.parametrize("kind", ["POINT", "SPOT", "AREA"])
def test_a_lamps_shadow_depth_range_scales_with_the_scene(kind):
    """One scene built at 1 mm, 1 m and 1 km: a lamp's perspective slots span the same share
    of its distances (near and far planes times the scale), so its shadows are the same at
    every scale; a near plane floored in scene units clipped a millimetre scene's blockers."""
    ranges = {}
    for scale in (1e-3, 1.0, 1e3):
        objects = [(quad((0, 0, 0), (4 * scale, 0, 0), (0, 4 * scale, 0)), None, 0),
                   (box((-0.4 * scale, 0.6 * scale, 0), (0.2 * scale, 1.2 * scale, 1.0 * scale)), None, 0)]
        lamp = dict(kind=kind, position=(1.5 * scale, -1.5 * scale, 2.5 * scale), direction=(-0.4, 0.4, -1.0))
        scene = SceneData(Geometry.from_objects(objects), MaterialTable.from_rows([{}]), Lights.from_rows([lamp]),
                          Sky())
        layout = shadow_views(scene, SceneBounds.of(scene))
        first, count = layout.per_light[0]
        ranges[scale] = [(view.near / scale, view.far / scale) for view in layout.views[first:first + count]]
    assert np.allclose(ranges[1e-3], ranges[1.0], rtol=1e-4)
    assert np.allclose(ranges[1e3], ranges[1.0], rtol=1e-4)
