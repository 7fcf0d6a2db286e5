# SPDX-License-Identifier: GPL-3.0-or-later
"""A quick check that this machine's OpenGL runs Hybrid RT correctly (Preferences > Test GPU).

Drivers differ in what they accept of GLSL and in how they run compute shaders; an artist
with a new GPU or driver wants to know at once whether the engine works there, not after a
long render. The test renders a small scene (a mirror ball and a glass ball on a floor, under
a sun) in every mode, which compiles and runs every pass, checks the images are finite and
that the hybrid trace agrees with the full BVH where the near cube holds the whole scene,
then builds an LBVH and compares its closest hits with a brute-force CPU intersection of the
same rays. Each step reports what it found, so a failure names the step and the error (a
shader's compile log, a mismatch count).
"""
from __future__ import annotations

import time
import traceback
from dataclasses import dataclass, field

import numpy as np

from ..frame.renderer import Renderer
from ..gpu import gl_context
from ..passes.lbvh import lbvh
from ..scene.camera import Camera, look_at
from ..scene.geometry import Geometry
from ..scene.data import Lights, MaterialTable, SceneData, Sky
from ..scene.settings import MODES, RenderSettings

# Rays whose closest hits the GPU and the CPU must agree on (same triangle, t within 1e-3).
TRACE_RAYS = 256
AGREEMENT_REQUIRED = 0.99
# HYBRID with a near cube holding the scene traces exactly as FULL_BVH: images equal to this.
HYBRID_MAX_DIFFERENCE = 1e-3


@dataclass
class SelfTestResult:
    """Each step's name, whether it passed, and what it found."""

    steps: list[tuple[str, bool, str]] = field(default_factory=list)
    renderer: str = ""

    @property
    def ok(self) -> bool:
        return bool(self.steps) and all(passed for _, passed, _ in self.steps)

    def summary(self) -> str:
        failed = [f"{name}: {detail}" for name, passed, detail in self.steps if not passed]
        if failed:
            return "GPU test failed. " + " | ".join(failed)
        return f"GPU test passed on {self.renderer}: " + ", ".join(f"{name} ({detail})" for name, _, detail in self.steps)


def _sphere(center, radius: float, segments: int = 16, rings: int = 8) -> tuple[np.ndarray, np.ndarray]:
    theta = np.linspace(0.0, np.pi, rings + 1)
    phi = np.linspace(0.0, 2.0 * np.pi, segments + 1)
    grid = np.stack(np.meshgrid(theta, phi, indexing="ij"), axis=-1)
    unit = np.stack([np.sin(grid[..., 0]) * np.cos(grid[..., 1]), np.sin(grid[..., 0]) * np.sin(grid[..., 1]),
                     np.cos(grid[..., 0])], axis=-1)
    a, b, c, d = unit[:-1, :-1], unit[:-1, 1:], unit[1:, 1:], unit[1:, :-1]
    normals = np.concatenate([np.stack([a, c, b], axis=2), np.stack([a, d, c], axis=2)]).reshape(-1, 3, 3)
    return (np.asarray(center) + radius * normals).astype(np.float32), normals.astype(np.float32)


def self_test_scene() -> tuple[SceneData, Camera]:
    """A mirror ball and a glass ball on a floor under a sun, and a camera looking at them."""
    mirror, mirror_n = _sphere((-0.8, 0.0, 0.0), 0.7)
    glass, glass_n = _sphere((0.8, 0.0, 0.0), 0.7)
    floor = np.array([[[-4, -4, -0.7], [4, -4, -0.7], [4, 4, -0.7]],
                      [[-4, -4, -0.7], [4, 4, -0.7], [-4, 4, -0.7]]], np.float32)
    materials = MaterialTable.from_rows([
        dict(base_color=(0.9, 0.9, 0.9), reflectivity=1.0),
        dict(base_color=(1.0, 1.0, 1.0), transmission=1.0, ior=1.5),
        dict(base_color=(0.6, 0.5, 0.4)),
    ])
    geometry = Geometry.from_objects([(mirror, mirror_n, 0), (glass, glass_n, 1), (floor, None, 2)])
    scene = SceneData(geometry, materials, Lights.from_rows([dict(kind="SUN", direction=(0.3, 0.4, -1),
                                                                  color=(3, 3, 3))]), Sky(color=(0.3, 0.4, 0.6)))
    return scene, Camera(matrix_world=look_at((0.0, -4.0, 1.5), (0.0, 0.0, 0.0)), width=48, height=32)


def _brute_force(triangles: np.ndarray, origins: np.ndarray, directions: np.ndarray):
    """Closest hit per ray by testing every triangle (Möller-Trumbore, float64)."""
    v0, v1, v2 = (triangles[:, k].astype(np.float64) for k in range(3))
    e1, e2 = v1 - v0, v2 - v0
    t_best = np.full(len(origins), np.inf)
    tri_best = np.full(len(origins), -1)
    for i, (o, d) in enumerate(zip(origins.astype(np.float64), directions.astype(np.float64))):
        p = np.cross(d, e2)
        det = np.einsum("ij,ij->i", e1, p)
        ok = np.abs(det) > 1e-12
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        s = o - v0
        u = np.einsum("ij,ij->i", s, p) * inv
        q = np.cross(s, e1)
        v = (q @ d) * inv
        t = np.einsum("ij,ij->i", e2, q) * inv
        hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 1e-6)
        if hit.any():
            k = int(np.argmin(np.where(hit, t, np.inf)))
            t_best[i], tri_best[i] = t[k], k
    return t_best, tri_best


def _step(result: SelfTestResult, name: str, check) -> None:
    start = time.perf_counter()
    try:
        passed, detail = check()
    except Exception as exc:  # noqa: BLE001 - a failing step is the test's finding, not a crash
        traceback.print_exc()
        passed, detail = False, f"{type(exc).__name__}: {exc}"
        _ = gl_context.get_context().error  # read (and so clear) what the failure left flagged
    result.steps.append((name, passed, f"{detail}, {(time.perf_counter() - start) * 1e3:.0f} ms" if passed else detail))


def run_self_test() -> SelfTestResult:
    """Run every step (each is run even when an earlier one failed)."""
    result = SelfTestResult()
    try:
        result.renderer = gl_context.renderer_name()
    except gl_context.GLUnavailableError as exc:
        result.steps.append(("OpenGL 4.3 context", False, str(exc)))
        return result
    scene, camera = self_test_scene()
    made: list[Renderer] = []

    def compile_passes():
        made.append(Renderer())  # compiles the raster and shading passes
        return True, "raster and shading passes"
    _step(result, "compile the passes", compile_passes)
    renderer = made[0] if made else None
    images: dict[str, np.ndarray] = {}
    try:
        for mode in MODES:
            def render(mode=mode):
                if renderer is None:
                    return False, "no renderer (its passes did not compile)"
                settings = RenderSettings(mode=mode, cube_resolution=32, shadow_resolution=128, near_size=50.0,
                                          cube_far=100.0)
                image = renderer.render(scene, camera, settings).image  # compiles the mode's passes
                images[mode] = image
                return bool(np.isfinite(image).all()), f"{image.shape[1]}x{image.shape[0]}"
            _step(result, f"render {mode}", render)

        def hybrid_matches():
            if "HYBRID" not in images or "FULL_BVH" not in images:
                return False, "needs both renders"
            difference = float(np.abs(images["HYBRID"] - images["FULL_BVH"]).max())
            return difference <= HYBRID_MAX_DIFFERENCE, f"largest difference {difference:.2g}"
        _step(result, "HYBRID equals FULL_BVH in a near cube holding the scene", hybrid_matches)
    finally:
        if renderer is not None:
            renderer.release()

    def trace_agrees():
        rng = np.random.default_rng(7)
        triangles = scene.geometry.triangles
        origins = np.tile(np.asarray(camera.position, np.float32), (TRACE_RAYS, 1))
        directions = (rng.uniform(-1, 1, (TRACE_RAYS, 3)) * (0.5, 0.2, 0.4) + (0, 1, -0.3)).astype(np.float32)
        t_gpu, tri_gpu = lbvh.trace_closest(triangles, origins, directions)
        t_cpu, tri_cpu = _brute_force(triangles, origins, directions)
        same_t = np.isclose(t_gpu, t_cpu, rtol=1e-3) | (np.isinf(t_gpu) & np.isinf(t_cpu))
        agreement = float(np.mean((tri_gpu == tri_cpu) & same_t))
        return agreement >= AGREEMENT_REQUIRED, f"{100 * agreement:.1f} % of {TRACE_RAYS} rays agree with the CPU"
    _step(result, "LBVH trace against the CPU", trace_agrees)
    return result
