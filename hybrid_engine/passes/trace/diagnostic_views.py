# SPDX-License-Identifier: GPL-3.0-or-later
"""The diagnostic views: where each pixel's rays and time go, counted by the trace pass.

The paper's Figure 4 colours each pixel by where its first reflection starts (PROVENANCE
mode). These views go further, for an artist sizing the near cube or an engineer reading a
timing report; each renders a HYBRID frame whose trace pass (hybrid_trace.comp.glsl,
``DIAGNOSTIC``) also counts, per pixel:

``BOUNCES``       the deepest bounce any of its rays reached (0: it spawns none);
``CUBE_STEPS``    the cube-map march steps all its rays took (pyramid cells visited by the
                  hierarchical march, samples taken by the sampled one);
``BVH_NODES``     the BVH nodes all its rays visited;
``BOUNCE_PATHS``  where its rays of bounce ``diagnostic_bounce`` ended: a bit each for a BVH
                  hit (1), a cube-map hit (2) and the sky (4).

The counts come back as ``FrameResult.diagnostic`` and are drawn in false colour by the
kernel; ``legend`` describes the colours as data (``FrameResult.legend``), which whoever
shows the image paints (reports/diagnostic_legend.py: the viewport and F12 alike, so a saved
render keeps it).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...scene.settings import DIAGNOSTIC_VIEWS, RenderSettings

# The kernel's view numbers (DIAG_* in hybrid_trace.comp.glsl).
VIEW_CODES = {"BOUNCES": 1, "CUBE_STEPS": 2, "BVH_NODES": 3, "BOUNCE_PATHS": 4}
# Five stops from few to many (linear RGB): dark blue, blue, green, yellow, red.
RAMP = ((0.02, 0.02, 0.25), (0.0, 0.25, 1.0), (0.0, 0.8, 0.2), (1.0, 0.85, 0.0), (1.0, 0.05, 0.0))
# Bounce Paths: no ray reached the bounce, then the BVH, the cube map and the sky (blue and
# red as in the paper's Figure 4); a pixel whose rays ended in several shows their mean.
PATH_COLOURS = ((0.3, 0.3, 0.3), (0.0, 0.2, 1.0), (1.0, 0.05, 0.0), (0.1, 0.9, 0.2))
PATH_LABELS = ("no ray at this bounce", "BVH", "cube map", "sky")
# Pixels that spawn no secondary ray (diffuse surfaces, the background).
UNTRACED = (0.12, 0.12, 0.12)
# The counts shown in the ramp's last colour: per pixel, all its rays together.
CUBE_STEPS_SCALE = 256.0
BVH_NODES_SCALE = 512.0

@dataclass(frozen=True)
class LegendEntry:
    """One line of a diagnostic view's legend: a colour swatch and what it means."""

    label: str
    colour: tuple[float, float, float]


def is_diagnostic(settings: RenderSettings) -> bool:
    return settings.mode in DIAGNOSTIC_VIEWS


def scale(settings: RenderSettings) -> float:
    """The count shown in the ramp's last colour: the deepest possible bounce (the depth
    limit's extra ray included), or a fixed count of steps or nodes."""
    if settings.mode == "BOUNCES":
        return float(settings.max_depth + min(settings.max_depth, 1))
    return CUBE_STEPS_SCALE if settings.mode == "CUBE_STEPS" else BVH_NODES_SCALE


def ramp_colour(x: float) -> tuple[float, float, float]:
    """The ramp at ``x`` in [0, 1], as the kernel computes it (diag_ramp)."""
    f = min(max(x, 0.0), 1.0) * 4.0
    i = min(int(f), 3)
    a, b = np.asarray(RAMP[i]), np.asarray(RAMP[i + 1])
    return tuple(float(v) for v in a + (b - a) * (f - i))


def legend(settings: RenderSettings) -> list[LegendEntry]:
    """The legend of the view ``settings.mode``: the ramp's five stops with their counts, or
    the Bounce Paths colours, and the colour of pixels without rays."""
    if settings.mode == "BOUNCE_PATHS":
        entries = [LegendEntry(f"bounce {settings.diagnostic_bounce}: {label}", colour)
                   for label, colour in zip(PATH_LABELS, PATH_COLOURS)]
    elif settings.mode == "BOUNCES":
        top = int(scale(settings))
        entries = [LegendEntry(f"{k} bounce{'' if k == 1 else 's'}", ramp_colour(k / max(top, 1)))
                   for k in range(1, top + 1)]
    else:
        top = scale(settings)
        title = "cube map steps" if settings.mode == "CUBE_STEPS" else "BVH nodes"
        entries = [LegendEntry(f"{'>= ' if k == 4 else ''}{top * k / 4:g} {title}", ramp_colour(k / 4))
                   for k in range(5)]
    entries.append(LegendEntry("no reflection or refraction", UNTRACED))
    return entries


def kernel_uniforms(settings: RenderSettings) -> dict:
    """The DIAGNOSTIC kernel's uniforms for the view ``settings.mode``."""
    return {
        "u_diag_view": VIEW_CODES[settings.mode],
        "u_diag_bounce": int(settings.diagnostic_bounce),
        "u_diag_scale": scale(settings),
        "u_diag_ramp": np.asarray(RAMP, np.float32).tobytes(),
        "u_diag_paths": np.asarray(PATH_COLOURS, np.float32).tobytes(),
        "u_diag_untraced": UNTRACED,
    }
