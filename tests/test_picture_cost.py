# SPDX-License-Identifier: GPL-3.0-or-later
"""The picture's cost benchmark renders the features on and switched off, and its switches
reach the shaders (a switch that compiled into nothing would measure nothing)."""
from __future__ import annotations

import json
import re
import subprocess
import sys

import numpy as np

from conftest import REPO_ROOT
from hybrid_engine import Camera, Geometry, Lights, MaterialTable, RenderSettings, SceneData, Sky
from hybrid_engine.gpu import shader_loader
from hybrid_engine.scene.camera import look_at
from hybrid_engine.frame.renderer import Renderer
from scenes_analytic import quad

from benchmarks.picture_cost import OFF_DEFINES


def sky_lit_plane() -> tuple[SceneData, Camera]:
    """A grey plane under a white World, no lamps: lit by the World alone."""
    geometry = Geometry.from_objects([(quad((-5, -5, 0), (10, 0, 0), (0, 10, 0)), None, 0)])
    scene = SceneData(geometry, MaterialTable.from_rows([dict(base_color=(0.8,) * 3)]), Lights.empty(),
                      Sky(color=(1.0, 1.0, 1.0)))
    return scene, Camera(matrix_world=look_at((0.0, -2.0, 2.0), (0.0, 0.0, 0.0)), width=32, height=24)


def test_every_switch_of_the_off_variant_is_tested_in_the_shaders():
    sources = "\n".join(p.read_text() for p in (REPO_ROOT / "gpu_shaders").rglob("*.glsl"))
    for name in OFF_DEFINES:
        assert re.search(rf"#if(def)?\s+(defined\()?{name}\b", sources), name


def test_compiled_with_adds_its_defines_inside_the_block_only(gl):
    plain = shader_loader.compute(gl, "shading/deferred_shade.comp.glsl")
    with shader_loader.compiled_with({"NO_WORLD_LIGHT": 1}):
        variant = shader_loader.compute(gl, "shading/deferred_shade.comp.glsl")
    assert variant is not plain
    assert shader_loader.compute(gl, "shading/deferred_shade.comp.glsl") is plain


def test_without_world_light_a_sky_lit_plane_renders_black(gl):
    scene, camera = sky_lit_plane()
    settings = RenderSettings(mode="RASTER", ao_distance=0.0)
    lit = Renderer(gl)
    with shader_loader.compiled_with({"NO_WORLD_LIGHT": 1}):
        dark = Renderer(gl)
        black = dark.render(scene, camera, settings).image
    try:
        image = lit.render(scene, camera, settings).image
    finally:
        lit.release()
        dark.release()
    assert float(np.min(image[..., :3])) > 0.1  # the plane fills the view: no sky pixel
    assert float(np.max(black[..., :3])) == 0.0


def test_quick_run_reports_both_variants_and_the_ratio(tmp_path):
    out = tmp_path / "cost.json"
    proc = subprocess.run([sys.executable, "-m", "benchmarks.picture_cost", "--quick", "--rounds", "1",
                           "--frames", "1", "--json", str(out)],
                          cwd=REPO_ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert "on / off:" in proc.stdout
    report = json.loads(out.read_text())
    assert report["frames"] == 1
    for name in ("on", "off"):
        assert report[name]["median_ms"] > 0 and "trace" in report[name]["passes"]
    assert report["ratio_median"] == round(report["on"]["median_ms"] / report["off"]["median_ms"], 4)
    # The switches took: without the World's light the frame is darker.
    assert report["off"]["mean_radiance"] < report["on"]["mean_radiance"]


def test_quick_light_run_compares_the_traced_light_with_the_screen_space_one(tmp_path):
    out = tmp_path / "light.json"
    proc = subprocess.run([sys.executable, "-m", "benchmarks.picture_cost", "--quick", "--rounds", "1",
                           "--frames", "1", "--light", "--json", str(out)],
                          cwd=REPO_ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    report = json.loads(out.read_text())
    assert report["comparison"] == "light" and report["bar"] == 1.35
    # The traced light runs its gather and the denoiser; the screen-space variant neither.
    assert "denoise" in report["on"]["passes"] and "denoise" not in report["off"]["passes"]
    assert report["off_settings"] == {"world_light": "SCREEN"}
