# SPDX-License-Identifier: GPL-3.0-or-later
"""Tooling that measures and exercises the renderer from a checkout; it never ships.

The benchmark (``python -m benchmarks.bench``, no Blender needed), the scenes it renders
(the procedural Chess scene, and the scene library that builds the paper's scenes in
Blender), and the numpy LBVH reference the GPU build is checked against. They import the
renderer core as the top-level ``hybrid_engine`` package, as the tests do, so the repository
root must be on ``sys.path`` (running from it does that; ``scripts/addon_loader.py`` does it
for the scripts). The extension zip leaves this folder out (``blender_manifest.toml``).
"""
