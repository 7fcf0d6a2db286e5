# SPDX-License-Identifier: GPL-3.0-or-later
"""docs/ARCHITECTURE.md says what is true now: its tables of the frame's passes are the
passes' own declarations (what each reads and writes, its folder), for HYBRID and for the
modes and settings that change a declaration."""
from __future__ import annotations

import re

import pytest

from conftest import REPO_ROOT
from hybrid_engine import RenderSettings
from hybrid_engine.frame.renderer import Renderer

DOC = REPO_ROOT / "docs" / "ARCHITECTURE.md"
NAMES = re.compile(r"`([a-z_]+)`")


def table_rows() -> list[list[str]]:
    rows = []
    for line in DOC.read_text(encoding="utf-8").splitlines():
        if line.startswith("| ") and not line.startswith("| ---"):
            rows.append([cell.strip() for cell in line.strip("|").split("|")])
    return rows


def names(cell: str) -> set[str]:
    return set(NAMES.findall(cell))


@pytest.fixture(scope="module")
def passes_of(gl):
    renderer = Renderer(gl)
    yield renderer.passes
    renderer.release()


def test_the_hybrid_table_is_every_pass_in_order_with_its_declarations(passes_of):
    settings = RenderSettings(mode="HYBRID")
    documented = [row for row in table_rows() if len(row) == 6 and row[1].startswith("`") and row[0] != "step"
                  and row[1] != "the renderer"]
    passes = passes_of(settings, accumulate=True)  # as the viewport and final renders run it
    assert [(names(r[0]).pop(), r[1].strip("`")) for r in documented] == [(p.name, type(p).__name__) for p in passes]
    for row, frame_pass in zip(documented, passes):
        io = frame_pass.io(settings)
        assert names(row[3]) == set(io.reads), row
        assert names(row[4]) == set(io.writes), row
        folder = type(frame_pass).__module__.split(".")[2]
        assert row[2] == f"`{folder}/`", row


@pytest.mark.parametrize(("label", "settings", "cls"), [
    ("FULL_BVH (no", RenderSettings(mode="FULL_BVH"), "LBVHBuildPass"),
    ("FULL_BVH", RenderSettings(mode="FULL_BVH"), "HybridTracer"),
    ("PROVENANCE", RenderSettings(mode="PROVENANCE"), "HybridTracer"),
    ("FULL_BVH", RenderSettings(mode="FULL_BVH"), "DiffuseLightPass"),
    ("PROVENANCE and RASTER", RenderSettings(mode="HYBRID", world_light="SCREEN"), "ScreenSpaceOcclusion"),
    ("PROVENANCE and RASTER", RenderSettings(mode="RASTER"), "ScreenSpaceOcclusion"),
    ("Depth, Normal or Denoising", RenderSettings(mode="HYBRID"), "DataPassesPass"),
    ("*Lit Cube Map*", RenderSettings(mode="HYBRID", lit_cube=True), "CubeLightPass"),
    ("*Lit Cube Map*", RenderSettings(mode="HYBRID", lit_cube=True), "HybridTracer"),
    ("*Denoise*", RenderSettings(mode="HYBRID"), "SurfaceMotionPass"),
    ("*Denoise*", RenderSettings(mode="HYBRID"), "DenoisePass"),
])
def test_the_variants_table_gives_each_changed_declaration(passes_of, label, settings, cls):
    rows = [r for r in table_rows() if len(r) == 4 and r[0].startswith(label) and r[1] == f"`{cls}`"]
    assert len(rows) == 1, (label, cls)
    (frame_pass,) = [p for p in passes_of(settings, True, True, True) if type(p).__name__ == cls]
    io = frame_pass.io(settings)
    assert names(rows[0][2]) == set(io.reads) and names(rows[0][3]) == set(io.writes)


@pytest.mark.parametrize("cls", ["LightPassesPass", "DeferredShadePass", "HybridTracer"])
def test_the_light_passes_rows_give_their_declarations(passes_of, cls):
    settings = RenderSettings(mode="HYBRID")
    rows = [r for r in table_rows() if len(r) == 4 and r[0].startswith("Light passes asked for")
            and r[1] == f"`{cls}`"]
    assert len(rows) == 1, cls
    try:
        (frame_pass,) = [p for p in passes_of(settings, True, light=True) if type(p).__name__ == cls]
        io = frame_pass.io(settings)
        assert names(rows[0][2]) == set(io.reads) and names(rows[0][3]) == set(io.writes)
    finally:
        passes_of(settings, True)  # the shared passes back to a frame without light passes


def test_the_vector_row_gives_its_declaration(passes_of):
    settings = RenderSettings(mode="HYBRID")
    rows = [r for r in table_rows() if len(r) == 4 and r[0].startswith("Vector pass asked for")
            and r[1] == "`VectorPass`"]
    assert len(rows) == 1
    (frame_pass,) = [p for p in passes_of(settings, True, vector=True) if type(p).__name__ == "VectorPass"]
    io = frame_pass.io(settings)
    assert names(rows[0][2]) == set(io.reads) and names(rows[0][3]) == set(io.writes)
