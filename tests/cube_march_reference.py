# SPDX-License-Identifier: GPL-3.0-or-later
"""An independent numpy march through a G-buffer cube map (paper §3.4), in float64.

It re-derives everything from the paper and the documented rule in
gpu_shaders/include/cube_march.glsl without importing hybrid_engine: the six 90.2° face
cameras (GL cube-map orientation), the map ray in NDC, the n = n_min + |d_m.z| (n_max - n_min)
samples, the thickness hit rule with its depth bias (one texel of the axial depth's slope)
and bisection, and face switching to the first face that contains the exit point.
``hierarchical=True`` gives the continuous rule of the hierarchical march instead: every
texel the map ray crosses (found by listing all texel-edge crossings, not by walking a
pyramid) is tested against its hit interval (A, B].
``back_layer=True`` reads the atlas's second row of faces as the back layer: where a front
surface has a back face of its own material behind it, B is that back face (less its bias)
instead of the thickness stretch, and a ray reaching the interval from behind hits the back
layer's texel.
``hidden_exit=True`` adds the hidden-exit rule: a ray leaving through a far plane at a point
behind the surface stored at that point's texel (past A, its depth bias included) hits that
surface instead of the sky.
Tests feed it the same atlas the GPU marched (read back from the GL textures) and compare
outcomes ray by ray.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

FOV = math.radians(90.2)
DIRECTIONS = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
UPS = np.array([[0, -1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1], [0, -1, 0], [0, -1, 0]], float)
SKY, HIT, TO_BVH = 0, 1, 2
MAX_SWITCHES = 8
REFINE_STEPS = 6
CONTAINS_EPS = 1e-5
BIAS_RELATIVE = 1e-4
MAX_SLOPE = 8.0


def face_axes(face: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World directions of a face's image right and up and of its forward axis."""
    back = -DIRECTIONS[face]
    right = np.cross(UPS[face], back)
    right /= np.linalg.norm(right)
    return right, np.cross(back, right), DIRECTIONS[face]


def face_matrices(center, near: float, far: float) -> np.ndarray:
    """(6, 4, 4) world -> clip of the six faces."""
    f = 1.0 / math.tan(FOV / 2)
    proj = np.array([[f, 0, 0, 0], [0, f, 0, 0],
                     [0, 0, -(far + near) / (far - near), -2 * far * near / (far - near)],
                     [0, 0, -1, 0]])
    out = []
    c = np.asarray(center, float)
    for face in range(6):
        right, true_up, forward = face_axes(face)
        rot = np.stack([right, true_up, -forward])  # rows: camera axes in world
        view = np.eye(4)
        view[:3, :3] = rot
        view[:3, 3] = -rot @ c
        out.append(proj @ view)
    return np.array(out)


@dataclass
class MarchResult:
    kind: int
    face: int
    texel: tuple[int, int]
    position: np.ndarray
    t: float
    switches: int
    steps: int = 0  # samples taken (sampled march; the bisection of a hit not counted)


class CubeMapReference:
    """depth: (res, 6 res) window depths in [0, 1] ((2 res, 6 res) with the back layer in
    rows res..2 res); normal_material: the same rows, 4 channels, w = ±(material + 1) (0 =
    empty); thickness: per-material thickness."""

    def __init__(self, depth, normal_material, thickness, center, near, far, n_min, n_max,
                 hierarchical: bool = False, back_layer: bool = False, hidden_exit: bool = False):
        self.depth = np.asarray(depth, np.float64)
        self.nm = np.asarray(normal_material, np.float64)
        self.res = self.depth.shape[1] // 6
        self.back_layer = back_layer
        assert self.depth.shape[0] == (2 if back_layer else 1) * self.res
        self.thickness = np.asarray(thickness, np.float64)
        self.center = np.asarray(center, np.float64)
        self.near, self.far = float(near), float(far)
        self.n_min, self.n_max = int(n_min), int(n_max)
        self.vp = face_matrices(center, near, far)
        self.inv = np.linalg.inv(self.vp)
        self.hierarchical = hierarchical
        self.hidden_exit = hidden_exit

    def ndc(self, r):
        n, f = self.near, self.far
        return ((f + n) - 2 * f * n / r) / (f - n)

    def bias(self, face, ndc, surface, normal):
        """One texel of the axial depth's slope: the plane n.x = c seen along
        w = u right + v up + forward ((u, v) tangent coordinates) lies at depth c / (n.w),
        whose derivatives in u and v are the depth times -(n.right, n.up) / (n.w)."""
        right, up, forward = face_axes(face)
        u, v = np.asarray(ndc[:2], float) * math.tan(FOV / 2)
        facing = abs(normal @ (u * right + v * up + forward))
        lateral = math.hypot(normal @ right, normal @ up)
        slope = lateral / facing if lateral < facing * MAX_SLOPE else MAX_SLOPE
        texel_angle = 2 * math.tan(FOV / 2) / self.res
        return surface * (BIAS_RELATIVE + texel_angle * slope)

    def interval_linear(self, tx, ty):
        """(A, B, back) of a front-layer texel as linear depths; None where nothing is stored.
        back: B is the back layer's surface (texel (tx, ty + res))."""
        nm = self.nm[ty, tx]
        if nm[3] == 0.0:
            return None
        face = tx // self.res
        xy = (np.array([tx - face * self.res, ty]) + 0.5) / self.res * 2 - 1
        z = self.depth[ty, tx] * 2 - 1
        surface = self.linear(z)
        normal = nm[:3] / np.linalg.norm(nm[:3])
        a = surface + self.bias(face, np.r_[xy, z], surface, normal)
        if self.back_layer and nm[3] > 0:
            back_nm = self.nm[ty + self.res, tx]
            if back_nm[3] == -nm[3]:  # the back side of the same material
                back_z = self.depth[ty + self.res, tx] * 2 - 1
                k = self.linear(back_z)
                if k > surface:
                    back_normal = back_nm[:3] / np.linalg.norm(back_nm[:3])
                    b = k - self.bias(face, np.r_[xy, back_z], k, back_normal)
                    return a, max(a, b), True
        material = int(abs(nm[3]) + 0.5) - 1
        thick = min(max(self.thickness[material], 0.0), 1.0)
        return a, max(a, surface + thick * (self.far - surface)), False

    def interval(self, tx, ty):
        """(A, B, back) of a front-layer texel with A, B as NDC depths; None where nothing
        is stored."""
        ab = self.interval_linear(tx, ty)
        return None if ab is None else (self.ndc(ab[0]), self.ndc(ab[1]), ab[2])

    def march_face_exact(self, face, a, dm, t_exit):
        """First texel along the map ray whose hit interval the ray reaches: (texel, xy)."""
        u0 = (a[:2] * 0.5 + 0.5) * self.res
        du = dm[:2] * 0.5 * self.res
        ts = [0.0, t_exit]
        for k in range(2):
            if abs(du[k]) > 1e-30:
                lo, hi = sorted((u0[k], u0[k] + du[k] * t_exit))
                edges = np.arange(math.ceil(lo), math.floor(hi) + 1)
                ts.extend(((edges - u0[k]) / du[k]).tolist())
        ts = np.unique(np.clip(ts, 0.0, t_exit))
        for t0, t1 in zip(ts[:-1], ts[1:]):
            if t1 <= t0:
                continue
            local = np.clip(np.floor(u0 + du * (0.5 * (t0 + t1))).astype(int), 0, self.res - 1)
            tx, ty = face * self.res + local[0], local[1]
            ab = self.interval(tx, ty)
            if ab is None:
                continue
            z0, z1 = a[2] + dm[2] * t0, a[2] + dm[2] * t1
            if max(z0, z1) > ab[0] and min(z0, z1) <= ab[1]:
                t_hit = t0
                if not ab[0] < z0 <= ab[1]:
                    target = ab[0] if z0 <= ab[0] else ab[1]
                    t_hit = min(max(t0 + (target - z0) / dm[2], t0), t1)
                if ab[2] and z0 - ab[0] > ab[1] - z0:
                    ty += self.res  # nearer the far side: the ray meets the back layer
                return (tx, ty), a[:2] + dm[:2] * t_hit
        return None

    def linear(self, z):
        n, f = self.near, self.far
        return 2 * f * n / ((f + n) - np.clip(z, -1, 1) * (f - n))

    def contains(self, clip) -> bool:
        return clip[3] > 0 and bool((np.abs(clip[:3]) <= clip[3] * (1 + CONTAINS_EPS)).all())

    def texel(self, face, xy):
        local = np.floor((np.asarray(xy) * 0.5 + 0.5) * self.res).astype(int)
        local = np.clip(local, 0, self.res - 1)
        return face * self.res + local[0], local[1]

    def unproject(self, face, ndc):
        w = self.inv[face] @ np.r_[ndc, 1.0]
        return w[:3] / w[3]

    def sample_hits(self, face, s, prev_lin):
        """(hit, piercing, texel, stored z) of one sample (the documented rule); texel and z
        are the back layer's for a ray that reaches a back surface from behind."""
        tx, ty = self.texel(face, s[:2])
        ab = self.interval_linear(tx, ty)
        if ab is None:
            return False, False, (tx, ty), 1.0
        z = self.depth[ty, tx] * 2 - 1
        a, b, back = ab
        r = self.linear(s[2])
        if back and prev_lin > b and r <= b:
            return True, True, (tx, ty + self.res), self.depth[ty + self.res, tx] * 2 - 1
        if r <= a:
            return False, False, (tx, ty), z
        if prev_lin <= a:
            return True, True, (tx, ty), z
        return r <= b, False, (tx, ty), z

    def march(self, origin, direction, t_start=0.0) -> MarchResult:
        self._steps = 0
        result = self._march(origin, direction, t_start)
        result.steps = self._steps
        return result

    def _march(self, origin, direction, t_start=0.0) -> MarchResult:
        o = np.asarray(origin, float)
        d = np.asarray(direction, float)
        d = d / np.linalg.norm(d)
        q = o + d * t_start
        face, clip = -1, None
        for i in range(6):
            c = self.vp[i] @ np.r_[q, 1.0]
            if self.contains(c):
                face, clip = i, c
                break
        result = MarchResult(SKY, face, (-1, -1), np.zeros(3), t_start, 0)
        if face < 0:
            return result
        for _ in range(MAX_SWITCHES + 1):
            result.face = face
            cd = self.vp[face] @ np.r_[d, 0.0]
            a = np.clip(clip[:3] / clip[3], -1, 1)
            dm = cd[:3] * clip[3] - clip[:3] * cd[3]
            dm /= np.linalg.norm(dm)
            bound = np.where(dm > 0, 1.0, -1.0)
            with np.errstate(divide="ignore", invalid="ignore"):
                t_axes = np.where(np.abs(dm) < 1e-30, 1e30, (bound - a) / dm)
            axis = int(np.argmin(t_axes))
            t_exit = max(t_axes[axis], 0.0)
            if self.hierarchical:
                found = self.march_face_exact(face, a, dm, t_exit)
                if found is not None:
                    (tx, ty), xy = found
                    position = self.unproject(face, np.r_[xy, self.depth[ty, tx] * 2 - 1])
                    return MarchResult(HIT, face, (tx, ty), position, float((position - o) @ d),
                                       result.switches)
                n = 0  # no samples: go on to the exit
            else:
                n = max(1, int(self.n_min + abs(dm[2]) * (self.n_max - self.n_min) + 0.5))
            prev_lin, t_prev = self.linear(a[2]), 0.0
            for k in range(1, n + 1):
                self._steps += 1
                t_k = t_exit * k / n
                s = a + dm * t_k
                hit, piercing, texel, z = self.sample_hits(face, s, prev_lin)
                if hit:
                    hit_s = s
                    if piercing:
                        lo, hi, lo_lin = t_prev, t_k, prev_lin
                        for _ in range(REFINE_STEPS):
                            mid = 0.5 * (lo + hi)
                            sm = a + dm * mid
                            h2, _, texel2, z2 = self.sample_hits(face, sm, lo_lin)
                            if h2:
                                hi, hit_s, texel, z = mid, sm, texel2, z2
                            else:
                                lo, lo_lin = mid, self.linear(sm[2])
                    position = self.unproject(face, np.r_[hit_s[:2], z])
                    return MarchResult(HIT, face, texel, position, float((position - o) @ d),
                                       result.switches)
                prev_lin, t_prev = self.linear(s[2]), t_k
            e = a + dm * t_exit
            if axis == 2:
                if dm[2] > 0:
                    tx, ty = self.texel(face, e[:2])
                    z = self.depth[ty, tx] * 2 - 1
                    ab = self.interval_linear(tx, ty) if self.hidden_exit else None
                    if ab is not None and self.linear(e[2]) > ab[0]:  # behind A, the biased surface
                        position = self.unproject(face, np.r_[e[:2], z])
                        return MarchResult(HIT, face, (tx, ty), position, float((position - o) @ d),
                                           result.switches)
                    return result
                position = self.unproject(face, e)
                return MarchResult(TO_BVH, face, (-1, -1), position, float((position - o) @ d),
                                   result.switches)
            nxt, nxt_clip, best = -1, None, 1e30
            for j in range(6):
                if j == face:
                    continue
                c = self.vp[j] @ self.inv[face] @ np.r_[e, 1.0]
                if self.contains(c):
                    nxt, nxt_clip = j, c
                    break
                v = 1e30 if c[3] <= 0 else np.abs(c[:3] / c[3]).max() - 1
                if v < best:
                    nxt, nxt_clip, best = j, c, v
            if nxt < 0 or nxt_clip[3] <= 0:
                return result
            face, clip = nxt, nxt_clip
            result.switches += 1
        return result
