# SPDX-License-Identifier: GPL-3.0-or-later
"""Which shape of a kernel a pass runs: GPU-shaped, or shaped for a CPU driver (llvmpipe).

The same algorithm wants different code on the two kinds of device. A GPU wants tens of
thousands of short-lived threads, workgroup-shared memory, many workgroups per scan and no
thread idling in its warp; llvmpipe runs a workgroup as a loop over 8-wide SIMD vectors on
two CPU cores, where long serial chunks, few dispatches and no barriers are what is fast.
Both variants of each kernel are kept and tested on llvmpipe (which runs any GLSL 4.5
correctly); this module decides which one a pass uses:

* by default, from the GL renderer string: a software rasterizer gets ``"cpu"``, any other
  renderer ``"gpu"``;
* overridden by the ``HYBRID_RT_KERNELS`` environment variable, or by ``set_override``
  (the add-on preference), either one family for every kernel (``"gpu"``, ``"cpu"``,
  ``"auto"``) or per kernel (``"sort=gpu,trace=cpu"``; kernels not named stay automatic).

Kernel names are short and stable, as the benchmark prints them: ``KERNELS`` lists them.
"""
from __future__ import annotations

import os

FAMILIES = ("gpu", "cpu")
AUTO = "auto"
ENVIRONMENT_VARIABLE = "HYBRID_RT_KERNELS"
# The kernels that come in both shapes.
KERNELS = ("sort", "scan", "trace", "readback", "faces", "vertices", "gather")

_SOFTWARE_WORDS = ("llvmpipe", "softpipe", "swrast", "lavapipe")
_override: str | None = None


class VariantError(ValueError):
    """An override that names an unknown kernel or family."""


def family_for_renderer(renderer: str) -> str:
    """The family a GL renderer string gets without an override."""
    name = renderer.lower()
    return "cpu" if any(word in name for word in _SOFTWARE_WORDS) else "gpu"


def parse_override(spec: str | None) -> dict[str, str]:
    """``spec`` as {kernel: family}; ``"*"`` stands for every kernel. Empty or ``"auto"``
    gives {}. Raises VariantError naming what it does not know."""
    choices: dict[str, str] = {}
    if spec is None:
        return choices
    for part in (piece.strip() for piece in spec.split(",")):
        if not part:
            continue
        kernel, _, family = part.rpartition("=")
        kernel, family = (kernel.strip() or "*"), family.strip().lower()
        if kernel != "*" and kernel not in KERNELS:
            raise VariantError(f"unknown kernel {kernel!r} in {spec!r}; known: {', '.join(KERNELS)}")
        if family == AUTO:
            continue
        if family not in FAMILIES:
            raise VariantError(f"unknown kernel family {family!r} in {spec!r}; use gpu, cpu or auto")
        choices[kernel] = family
    return choices


def set_override(spec: str | None) -> None:
    """Set the override for this process (None or "auto": follow the renderer); validated."""
    global _override
    parse_override(spec)
    _override = spec


def choose(kernel: str, renderer: str | None = None, override: str | None = None) -> str:
    """The family ``kernel`` runs: ``override`` (else ``set_override``'s, else the
    environment variable's), falling back to the renderer string (default: the shared
    context's)."""
    if kernel not in KERNELS:
        raise VariantError(f"unknown kernel {kernel!r}; known: {', '.join(KERNELS)}")
    if override is None:
        override = _override if _override is not None else os.environ.get(ENVIRONMENT_VARIABLE)
    choices = parse_override(override)
    if kernel in choices:
        return choices[kernel]
    if "*" in choices:
        return choices["*"]
    if renderer is None:
        from .gl_context import renderer_name

        renderer = renderer_name()
    return family_for_renderer(renderer)


def chosen(renderer: str | None = None, override: str | None = None) -> dict[str, str]:
    """Every kernel's family, for reports and the benchmark."""
    return {kernel: choose(kernel, renderer, override) for kernel in KERNELS}
