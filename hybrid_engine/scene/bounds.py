# SPDX-License-Identifier: GPL-3.0-or-later
"""The finite bounds of a scene's geometry: what shadow frusta are fitted to and what the
tracer clips its rays to."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .data import SceneData


@dataclass
class SceneBounds:
    """Axis-aligned bounds of every object with finite bounds (empty when none has)."""

    lo: np.ndarray
    hi: np.ndarray

    @property
    def empty(self) -> bool:
        return not (np.isfinite(self.lo).all() and (self.lo <= self.hi).all())

    @property
    def center(self) -> np.ndarray:
        return (self.lo + self.hi) * 0.5

    @property
    def radius(self) -> float:
        return float(max(np.linalg.norm(self.hi - self.lo) * 0.5, 1e-3))

    @classmethod
    def of(cls, scene: SceneData) -> "SceneBounds":
        b = scene.geometry.object_bounds.astype(np.float64)
        valid = np.isfinite(b).all(axis=(1, 2)) & (b[:, 0] <= b[:, 1]).all(axis=1) if len(b) else np.zeros(0, bool)
        if not valid.any():
            return cls(np.full(3, np.inf), np.full(3, -np.inf))
        return cls(b[valid, 0].min(axis=0), b[valid, 1].max(axis=0))
