# SPDX-License-Identifier: GPL-3.0-or-later
"""What changed in the scene's geometry since the last frame.

The paper rebuilds its BVH every frame so that anything may move (§3.3); everything else a
frame keeps (the shadow maps' static layer, a kept cube map and BVH) must know what moved.
The upload step finds it where it is cheap: the instance transform compares each instance's
table row with the last one and knows which meshes were deformed
(passes/scene_upload/instance_transform.py), and a flat geometry's conversion compares each
object's rows bit for bit (scene/geometry.py). A ``GeometryDelta`` is that answer as
triangle ranges: exactly the rows of the objects that changed, never a row of one that did
not, which the shadow layers rely on (passes/shadow_maps/shadow_cache.py).
"""
from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class GeometryDelta:
    """What changed between two frames' geometry.

    ``full``: everything is new (first frame, or the meshes' layout changed). Otherwise
    ``ranges`` lists the (first, count) triangle ranges of the objects that changed, empty
    when nothing changed.
    """

    full: bool
    ranges: tuple[tuple[int, int], ...] = field(default_factory=tuple)
    changed_triangles: int = 0
    # The upload's count: a consumer may apply a delta incrementally only when it applied the
    # previous one (sequence - 1); any other consumer starts over.
    sequence: int = 0

    @property
    def unchanged(self) -> bool:
        return not self.full and not self.ranges

    @classmethod
    def everything(cls, count: int, sequence: int = 0) -> "GeometryDelta":
        return cls(full=True, ranges=((0, int(count)),) if count else (), changed_triangles=int(count),
                   sequence=sequence)
