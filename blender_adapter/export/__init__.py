# SPDX-License-Identifier: GPL-3.0-or-later
"""The exporter's readers: Blender data to the renderer core's plain arrays, by kind.

``blender_adapter/scene_cache.py`` drives them over the evaluated depsgraph and keeps what
they read; each module reads one kind of data: ``meshes`` (evaluated meshes in object space),
``materials`` (Principled BSDF and its images), ``images`` (pixels, once per content, in the
scene's working space), ``lights``, ``world`` (the sky) and ``camera``. Everything the
depsgraph evaluated is seen as Blender's own engines see it: modifiers, shape keys,
armatures, geometry-nodes and collection instances, curves/text/metaballs that evaluate to
meshes. Hidden objects never reach us (the depsgraph filters by the render or viewport
visibility of its mode).

Speed matters because the viewport reads again on every change: all per-element work is
``foreach_get`` into numpy through Blender's raw attribute arrays plus vectorised gathers,
never a Python loop over vertices or triangles. Nothing here writes to Blender data.
"""
from __future__ import annotations

from .. import messages


def tell(message: str, *args) -> None:
    """A message for the artist (messages.py: it reaches ``report``)."""
    messages.tell(message % args if args else message)
