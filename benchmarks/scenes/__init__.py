# SPDX-License-Identifier: GPL-3.0-or-later
"""Procedural test scenes built in code (numpy only, no files, no Blender).

The paper evaluates the method on scenes that cannot be shipped with the project (the Chess
scene's pieces are a commercial model). The scenes here rebuild their character — triangle
count, materials, layout, animation — from code, so the benchmark and the tests can render
them anywhere: :func:`build_chess` is the paper's Chess scene (§4, Figures 4, 6 and 7).
"""
from __future__ import annotations

from .chess import CHESS_CUBE_FAR, CHESS_FRAMES, build_chess, chess_triangle_count

__all__ = ["CHESS_CUBE_FAR", "CHESS_FRAMES", "build_chess", "chess_triangle_count"]
