# SPDX-License-Identifier: GPL-3.0-or-later
"""Rigid motion over a shutter: the instance table's and the camera's matrices at a few
sub-frame steps, and their value at any time between.

Blender's Motion Blur opens the shutter for ``motion_blur_shutter`` frames, starting at the
frame, centred on it or ending at it (``motion_blur_position``). Cycles evaluates the scene
at a few sub-frame steps and interpolates each object's transform between them, decomposed
into translation, rotation and scale (``transform_motion_decompose``), so that a spinning
object sweeps an arc rather than a chord. ``MotionSteps`` keeps the steps' matrices and does
the same: translation and scale linearly, rotation by quaternion slerp, within the segment
of two steps that holds the time. Each accumulated sample of a final render is taken at its
own time in the shutter (``shutter_time``), so the samples' mean is the image integrated
over the shutter; only the matrices change from one sample to the next (the meshes stay on
the GPU), and the positions and normals of a mesh that deforms (its topology stays).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

SHUTTER_POSITIONS = ("START", "CENTER", "END")
# The golden ratio's fraction: the times i * phi mod 1 fill the shutter evenly for any count
# of samples, and are not the Halton points the pixel offsets use (accumulation.py).
_GOLDEN = 0.6180339887498949


class MotionError(ValueError):
    """Steps that describe no motion (no steps, times out of order, matrices of another shape)."""


def shutter_interval(shutter: float, position: str) -> tuple[float, float]:
    """(open, close) in frames relative to the frame, for Blender's Shutter length and
    Position (START: the frame opens it, CENTER: the frame is its middle, END: closes it)."""
    shutter = max(float(shutter), 0.0)
    if position == "START":
        return 0.0, shutter
    if position == "END":
        return -shutter, 0.0
    if position == "CENTER":
        return -0.5 * shutter, 0.5 * shutter
    raise MotionError(f"unknown shutter position {position!r} (one of {SHUTTER_POSITIONS})")


def step_times(shutter: float, position: str, steps: int) -> np.ndarray:
    """``steps`` (at least 2) evenly spaced sub-frame offsets from the shutter's opening to
    its closing, where the scene is evaluated."""
    opening, closing = shutter_interval(shutter, position)
    return np.linspace(opening, closing, max(int(steps), 2))


def shutter_time(index: int, opening: float, closing: float) -> float:
    """The time of sample ``index`` within the shutter (frames relative to the frame): a
    golden-ratio sequence, even over the shutter for any count of samples."""
    return opening + (closing - opening) * ((0.5 + index * _GOLDEN) % 1.0)


@dataclass(frozen=True)
class MotionSteps:
    """The matrices of the instance table (``instances``: (steps, K, 4, 4)) and of the camera
    (``camera``: (steps, 4, 4)) at the sub-frame offsets ``times`` (increasing), and the
    vertex positions and normals of the meshes that deform (``deformations``: the index of a
    mesh in the instance table's list -> (positions (steps, V, 3), normals (steps, N, 3)))."""

    times: np.ndarray
    instances: np.ndarray
    camera: np.ndarray
    deformations: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        times = np.asarray(self.times, np.float64).reshape(-1)
        instances = np.asarray(self.instances, np.float64)
        camera = np.asarray(self.camera, np.float64)
        if len(times) < 1 or (len(times) > 1 and not (np.diff(times) > 0).all()):
            raise MotionError(f"motion steps need increasing times, got {times}")
        if instances.ndim != 4 or instances.shape[0] != len(times) or instances.shape[2:] != (4, 4):
            raise MotionError(f"{len(times)} steps need (steps, K, 4, 4) instance matrices, got {instances.shape}")
        if camera.shape != (len(times), 4, 4):
            raise MotionError(f"{len(times)} steps need (steps, 4, 4) camera matrices, got {camera.shape}")
        if not (np.isfinite(instances).all() and np.isfinite(camera).all()):
            raise MotionError("motion matrices must be finite")
        for index, (positions, normals) in self.deformations.items():
            if positions.shape[0] != len(times) or normals.shape[0] != len(times):
                raise MotionError(f"mesh {index} deforms over {positions.shape[0]} steps, not {len(times)}")
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "instances", instances)
        object.__setattr__(self, "camera", camera)
        # Instances whose matrix is the same at every step: they keep it bit for bit, so the
        # upload finds their rows unchanged and transforms only what moves.
        moving = (instances != instances[:1]).any(axis=(0, 2, 3)) if instances.shape[1] else np.zeros(0, bool)
        object.__setattr__(self, "moving", moving)

    @property
    def camera_moves(self) -> bool:
        return bool((self.camera != self.camera[:1]).any())

    @property
    def anything_moves(self) -> bool:
        return bool(self.moving.any()) or self.camera_moves or bool(self.deformations)

    def mesh_arrays(self, index: int, time: float) -> tuple[np.ndarray, np.ndarray]:
        """Mesh ``index``'s vertex positions and normals at ``time``: linear between the
        steps that hold it (Cycles interpolates deformation motion steps linearly too), the
        normals renormalised."""
        positions, normals = self.deformations[index]
        times = self.times
        if len(times) == 1 or time <= times[0]:
            return positions[0], normals[0]
        if time >= times[-1]:
            return positions[-1], normals[-1]
        i = int(np.searchsorted(times, time, side="right")) - 1
        f = (time - times[i]) / (times[i + 1] - times[i])
        p = (1 - f) * positions[i] + f * positions[i + 1]
        n = (1 - f) * normals[i] + f * normals[i + 1]
        length = np.linalg.norm(n, axis=1, keepdims=True)
        return p.astype(np.float32), (n / np.where(length > 0, length, 1.0)).astype(np.float32)

    def instance_matrices(self, time: float, still: np.ndarray) -> np.ndarray:
        """The instance table's matrices at ``time`` (float32, (K, 4, 4)): ``still`` (the
        frame's own matrices) for the instances that do not move, interpolated for the rest."""
        out = np.array(still, np.float32, copy=True)
        which = np.flatnonzero(self.moving)
        if len(which):
            out[which] = self._at(time, self.instances[:, which]).astype(np.float32)
        return out

    def camera_matrix(self, time: float) -> np.ndarray:
        """The camera's world matrix at ``time``."""
        if not self.camera_moves:
            return self.camera[0].copy()
        return self._at(time, self.camera[:, None])[0]

    def _at(self, time: float, matrices: np.ndarray) -> np.ndarray:
        """(steps, n, 4, 4) → (n, 4, 4) at ``time``, clamped to the steps' range."""
        times = self.times
        if len(times) == 1 or time <= times[0]:
            return matrices[0].copy()
        if time >= times[-1]:
            return matrices[-1].copy()
        i = int(np.searchsorted(times, time, side="right")) - 1
        f = (time - times[i]) / (times[i + 1] - times[i])
        return interpolate(matrices[i], matrices[i + 1], f)


def interpolate(a: np.ndarray, b: np.ndarray, f: float) -> np.ndarray:
    """(n, 4, 4) matrices ``f`` of the way from ``a`` to ``b``, decomposed as Cycles does:
    translation and scale linearly, rotation by quaternion slerp (a turning object sweeps an
    arc, and its size holds)."""
    ta, ra, sa = _decompose(a)
    tb, rb, sb = _decompose(b)
    out = np.zeros_like(a)
    out[:, :3, :3] = _matrix_of(_slerp(ra, rb, f)) * ((1 - f) * sa + f * sb)[:, None, :]
    out[:, :3, 3] = (1 - f) * ta + f * tb
    out[:, 3, 3] = 1.0
    return out


def _decompose(m: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Translation, unit quaternion (w, x, y, z) and per-axis scale of each affine matrix; a
    mirroring matrix keeps its sign in the x scale."""
    linear = m[:, :3, :3]
    scale = np.linalg.norm(linear, axis=1)
    scale[scale == 0] = 1.0
    mirrored = np.linalg.det(linear) < 0
    scale[mirrored, 0] *= -1.0
    rotation = linear / scale[:, None, :]
    return m[:, :3, 3], _quaternion_of(rotation), scale


def _quaternion_of(r: np.ndarray) -> np.ndarray:
    """Unit quaternions (w, x, y, z) of rotation matrices (n, 3, 3), Shepperd's method: the
    largest of the four candidates keeps the division well conditioned."""
    n = len(r)
    q = np.zeros((n, 4))
    trace = r[:, 0, 0] + r[:, 1, 1] + r[:, 2, 2]
    diag = np.stack([trace, r[:, 0, 0], r[:, 1, 1], r[:, 2, 2]], axis=1)
    pick = np.argmax(diag, axis=1)
    for k in range(n):
        m = r[k]
        if pick[k] == 0:
            s = 2.0 * np.sqrt(max(1.0 + trace[k], 0.0))
            q[k] = (0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s)
        elif pick[k] == 1:
            s = 2.0 * np.sqrt(max(1.0 + m[0, 0] - m[1, 1] - m[2, 2], 0.0))
            q[k] = ((m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s)
        elif pick[k] == 2:
            s = 2.0 * np.sqrt(max(1.0 + m[1, 1] - m[0, 0] - m[2, 2], 0.0))
            q[k] = ((m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s)
        else:
            s = 2.0 * np.sqrt(max(1.0 + m[2, 2] - m[0, 0] - m[1, 1], 0.0))
            q[k] = ((m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s)
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def _slerp(a: np.ndarray, b: np.ndarray, f: float) -> np.ndarray:
    """Spherical interpolation of unit quaternions along the shorter arc."""
    dot = (a * b).sum(axis=1)
    b = np.where(dot[:, None] < 0, -b, b)
    dot = np.abs(dot)
    out = np.empty_like(a)
    close = dot > 0.9995  # nearly the same rotation: a normalised lerp is exact enough
    out[close] = (1 - f) * a[close] + f * b[close]
    theta = np.arccos(np.clip(dot[~close], -1.0, 1.0))
    sin = np.sin(theta)
    out[~close] = (np.sin((1 - f) * theta) / sin)[:, None] * a[~close] + (np.sin(f * theta) / sin)[:, None] * b[~close]
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def _matrix_of(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (n, 3, 3) of unit quaternions (w, x, y, z)."""
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=1),
    ], axis=1)
