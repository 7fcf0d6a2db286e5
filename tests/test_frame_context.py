# SPDX-License-Identifier: GPL-3.0-or-later
"""hybrid_engine/passes/frame_context.py and the renderer's use of it: every pass declares
what it reads and writes, the renderer checks the order before a frame runs and names the
pass and the resource when one is missing, and a running pass may touch only what it
declared."""
from __future__ import annotations

import numpy as np
import pytest

from hybrid_engine import Camera, Geometry, Lights, MaterialTable, RenderSettings, SceneData, Sky
from hybrid_engine.frame.renderer import MODE_STEPS, READBACK_READS, Renderer, frame_steps
from hybrid_engine.passes.frame_context import FrameContext, PassGraphError, PassIO, check_order
from hybrid_engine.scene.raster_view import RasterView
from hybrid_engine.scene.settings import MODES
from scenes_analytic import quad


class Step:
    """A pass that declares ``reads`` and ``writes`` and records that it ran."""

    def __init__(self, name: str, reads=(), writes=(), touch: str | None = None) -> None:
        self.name, self._io, self.touch, self.ran = name, PassIO(tuple(reads), tuple(writes)), touch, False

    def io(self, settings) -> PassIO:
        return self._io

    def run(self, frame: FrameContext) -> None:
        self.ran = True
        for name in self._io.reads:
            frame.read(name)
        for name in self._io.writes:
            frame.write(name, object())
        if self.touch is not None:
            frame.read(self.touch)


def test_an_order_where_a_pass_reads_what_no_earlier_pass_writes_fails_naming_both():
    passes = [Step("upload", ["scene_data"], ["scene"]), Step("lbvh_build", ["scene", "near_triangles"], ["bvh"])]
    with pytest.raises(PassGraphError, match=r"pass 'lbvh_build' .* reads 'near_triangles', which no earlier "
                                             r"pass writes .*earlier passes: upload"):
        check_order(passes, RenderSettings())
    check_order([Step("cull", ["scene_data"], ["near_triangles"]), *passes], RenderSettings())


def test_a_frame_end_that_reads_what_nobody_wrote_fails():
    with pytest.raises(PassGraphError, match="reads back 'color'"):
        check_order([Step("upload", ["scene_data"], ["scene"])], RenderSettings(), final_reads=["color"])


def test_a_running_pass_may_touch_only_what_it_declared():
    camera = Camera(width=4, height=4)
    frame = FrameContext(None, scene_data=object(), camera=camera, settings=RenderSettings(),
                         view=RasterView.from_camera(camera), outputs=None)
    honest = Step("upload", ["scene_data"], ["scene"])
    with frame.running(honest):
        honest.run(frame)
    sneaky = Step("shade", ["scene"], ["color"], touch="bvh")
    with pytest.raises(PassGraphError, match=r"pass 'shade' reads 'bvh', which it does not declare"):
        with frame.running(sneaky):
            sneaky.run(frame)
    writer = Step("trace", ["scene"], [])
    with pytest.raises(PassGraphError, match=r"pass 'trace' writes 'color', which it does not declare"):
        with frame.running(writer):
            frame.write("color", None)


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("world_light", ["RAYS", "SCREEN"])
def test_every_modes_passes_are_in_an_order_the_check_accepts_and_match_the_timing_rows(gl, mode, world_light):
    settings = RenderSettings(mode=mode, world_light=world_light)
    renderer = Renderer(gl)
    try:
        passes = renderer.passes(settings)
        check_order(passes, settings, final_reads=READBACK_READS)
        names = list(dict.fromkeys(p.name for p in passes))
        assert names + ["readback"] == list(MODE_STEPS[mode])
        # Accumulating, the frame ends with the running mean, which the read-back reads.
        passes = renderer.passes(settings, accumulate=True)
        check_order(passes, settings, final_reads=READBACK_READS + ("film",))
        names = list(dict.fromkeys(p.name for p in passes))
        assert names + ["readback"] == list(frame_steps(mode, accumulate=True)) and names[-1] == "accumulate"
    finally:
        renderer.release()


def _small_scene() -> SceneData:
    floor = quad((0.0, 0.0, -2.0), (3.0, 0.0, 0.0), (0.0, 3.0, 0.0))
    return SceneData(Geometry.from_objects([(floor, None, 0)]), MaterialTable.from_rows([dict()]),
                     Lights.empty(), Sky())


def test_the_renderer_refuses_a_pass_order_with_a_missing_input_before_any_pass_runs(gl, monkeypatch):
    """The cull dropped from a HYBRID frame: the LBVH would read a near-cube list nobody
    made. The renderer says so at setup, naming both, and renders nothing."""
    renderer = Renderer(gl)
    try:
        settings = RenderSettings(mode="HYBRID", cube_resolution=16)
        plan = [p for p in renderer.passes(settings) if p.name != "cull"]
        monkeypatch.setattr(renderer, "passes", lambda *_args: plan)
        ran = []
        monkeypatch.setattr(renderer.upload, "run", lambda frame: ran.append("upload"))
        with pytest.raises(PassGraphError, match=r"'lbvh_build' .* reads 'near_triangles'"):
            renderer.render(_small_scene(), Camera(width=8, height=8), settings)
        assert ran == []
    finally:
        renderer.release()


def test_the_traced_passes_are_siblings_the_renderer_runs_not_parts_of_the_tracer(gl):
    """The tracer keeps its kernel only: the cube map, the cull and the LBVH are passes of
    the frame, each run by the renderer, and the tracer reads what they wrote."""
    renderer = Renderer(gl)
    try:
        names = [type(p).__name__ for p in renderer.passes(RenderSettings(mode="HYBRID"))]
        assert names.index("CubeMapPass") < names.index("NearCubeCuller") < names.index("LBVHBuildPass") \
            < names.index("HybridTracer")
        reads = renderer.tracer.io(RenderSettings(mode="HYBRID")).reads
        assert {"bvh", "cube_map", "gbuffer", "lighting"} <= set(reads)
        assert not {"bvh", "cube_map"} & set(renderer.tracer.io(RenderSettings(mode="PROVENANCE")).reads)
        assert "cube_map" not in renderer.tracer.io(RenderSettings(mode="FULL_BVH")).reads
        assert not any(hasattr(renderer.tracer, name) for name in ("cube_map", "culler", "builder"))
        result = renderer.render(_small_scene(), Camera(width=8, height=8), RenderSettings(mode="HYBRID",
                                                                                          cube_resolution=16))
        assert np.isfinite(result.image).all()
    finally:
        renderer.release()
