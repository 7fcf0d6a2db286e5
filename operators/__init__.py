# SPDX-License-Identifier: GPL-3.0-or-later
"""Hybrid RT operators and viewport drawing: ``hybrid_rt.timing_report`` (per-pass timings
of a frame range), ``hybrid_rt.test_gpu`` (the GPU self-test) and the near-cube overlay
(``scene.hybrid_rt.show_near_cube``)."""
from __future__ import annotations

from . import near_cube_overlay, self_test, timing_report

_MODULES = (timing_report, near_cube_overlay, self_test)


def register() -> None:
    for module in _MODULES:
        module.register()


def unregister() -> None:
    for module in reversed(_MODULES):
        module.unregister()
