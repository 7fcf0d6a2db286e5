# SPDX-License-Identifier: GPL-3.0-or-later
"""A CPU Whitted ray tracer on embreex: the independent oracle of FULL_BVH images.

It shares no code with the GPU path (no shaders, no LBVH, no rasterizer): embree finds the
closest hits, numpy shades them with the same surface model as
``gpu_shaders/include/shading.glsl`` for smooth materials without a specular coat (emission +
Lambertian diffuse lit directly and by the uniform sky, a mirror lobe tinted by the base
colour, a clear-glass lobe with exact Fresnel, Snell refraction and total internal
reflection), and rays are followed breadth-first as wavefronts up to ``max_depth`` bounces;
the rays a hit at depth ``max_depth`` spawns are traced once more and the surfaces they meet
shaded without spawning rays, as in the tracer. Direct light uses shadow RAYS from embree where the GPU uses shadow maps:
scenes compared with it either have no occluder between a light and a visible diffuse
surface, or lights with ``cast_shadow`` off (then neither side tests visibility).

Light units are Blender's (see the project notes): sun strength = irradiance; point and spot
intensity = power / 4π, spot mask smoothstep over the blend; area ≈ Lambertian point emitter
power · cosθ / π. The sky is a constant colour (equirectangular environments are not
modelled here).
"""
from __future__ import annotations

import numpy as np
from embreex import rtcore_scene as rtcs
from embreex.mesh_construction import TriangleMesh

from hybrid_engine.scene.data import LIGHT_AREA, LIGHT_SPOT, LIGHT_SUN, SceneData

# Spawned rays (and shadow rays) leave the surface by this much relative to the position's
# magnitude, as the GPU tracer does.
OFFSET_RELATIVE = 1e-4
OFFSET_ABSOLUTE = 1e-4


def _normalize(v: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    with np.errstate(invalid="ignore", over="ignore"):
        length = np.linalg.norm(v, axis=-1, keepdims=True)
        ok = np.isfinite(length) & (length > 1e-15)
        return np.where(ok, v / np.where(ok, length, 1.0), fallback)


def _offset(p: np.ndarray, towards: np.ndarray) -> np.ndarray:
    scale = OFFSET_ABSOLUTE + OFFSET_RELATIVE * np.abs(p).max(axis=-1, keepdims=True)
    return p + towards * scale


def fresnel_dielectric(cos_i: np.ndarray, eta: np.ndarray) -> np.ndarray:
    """Unpolarised Fresnel reflectance, eta = n_t / n_i; 1 under total internal reflection."""
    sin2_t = (1.0 - cos_i**2) / eta**2
    tir = sin2_t >= 1.0
    cos_t = np.sqrt(np.maximum(1.0 - sin2_t, 0.0))
    rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    return np.where(tir, 1.0, 0.5 * (rs**2 + rp**2))


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


class WhittedReference:
    """Renders a SceneData through a Camera on the CPU (see module docstring)."""

    def __init__(self, scene: SceneData) -> None:
        self.scene = scene
        geo = scene.geometry
        tris = np.array(geo.triangles, np.float32)
        finite = np.isfinite(tris).all(axis=(1, 2))
        tris[~finite] = 0.0  # degenerate point: never hit
        self.triangles = tris
        self.embree = rtcs.EmbreeScene()
        if len(tris):
            TriangleMesh(self.embree, tris)
        self.normals = np.where(np.isfinite(geo.normals), geo.normals, 0.0).astype(np.float64)
        self.material_ids = geo.material_ids
        m = scene.materials
        self.base = m.base_color.astype(np.float64)
        self.emission = m.emission.astype(np.float64)
        self.reflectivity = np.clip(m.reflectivity.astype(np.float64), 0, 1)
        self.transmission = np.clip(m.transmission.astype(np.float64), 0, 1)
        self.ior = np.maximum(m.ior.astype(np.float64), 1.0)
        self.sky = np.asarray(scene.sky.color, np.float64) * scene.sky.strength

    # -- queries ---------------------------------------------------------------------------
    def intersect(self, origins: np.ndarray, dirs: np.ndarray):
        """(t, triangle, u, v, Ng) of the closest hits; triangle -1 on a miss."""
        n = len(origins)
        if n == 0 or len(self.triangles) == 0:
            return (np.full(n, np.inf), np.full(n, -1), np.zeros(n), np.zeros(n), np.zeros((n, 3)))
        res = self.embree.run(origins.astype(np.float32), dirs.astype(np.float32), output=1)
        tri = res["primID"].astype(np.int64)
        hit = res["geomID"] >= 0
        tri = np.where(hit, tri, -1)
        return (np.where(hit, res["tfar"], np.inf).astype(np.float64), tri,
                res["u"].astype(np.float64), res["v"].astype(np.float64), res["Ng"].astype(np.float64))

    def occluded(self, origins: np.ndarray, dirs: np.ndarray, dists: np.ndarray) -> np.ndarray:
        if len(origins) == 0 or len(self.triangles) == 0:
            return np.zeros(len(origins), bool)
        res = self.embree.run(origins.astype(np.float32), dirs.astype(np.float32),
                              dists=dists.astype(np.float32), output=1)
        return res["geomID"] >= 0

    # -- shading ---------------------------------------------------------------------------
    def direct_irradiance(self, p: np.ndarray, n: np.ndarray) -> np.ndarray:
        """Irradiance at points p with facing normals n from all lights, shadow rays."""
        lights = self.scene.lights
        total = np.zeros_like(p)
        for i in range(len(lights)):
            kind = int(lights.kind[i])
            color = lights.color[i].astype(np.float64)
            direction = _normalize(lights.direction[i].astype(np.float64), np.array([0.0, 0.0, -1.0]))
            if kind == LIGHT_SUN:
                to_light = np.broadcast_to(-direction, p.shape)
                dist = np.full(len(p), np.inf)
                dist2 = np.ones(len(p))
            else:
                delta = lights.position[i].astype(np.float64) - p
                dist2 = np.maximum((delta**2).sum(-1), 1e-12)
                dist = np.sqrt(dist2)
                to_light = delta / dist[:, None]
            cos_s = (n * to_light).sum(-1)
            e = color[None, :] * np.maximum(cos_s, 0.0)[:, None]
            if kind == LIGHT_AREA:
                cos_e = (direction[None, :] * -to_light).sum(-1)
                e *= (np.maximum(cos_e, 0.0) / (np.pi * dist2))[:, None]
            elif kind != LIGHT_SUN:
                e /= (4.0 * np.pi * dist2)[:, None]
                if kind == LIGHT_SPOT:
                    cos_angle = (direction[None, :] * -to_light).sum(-1)
                    cos_half = np.cos(np.clip(lights.spot_size[i] * 0.5, 0.0, np.pi / 2))
                    blend = max(float(np.clip(lights.spot_blend[i], 0, 1)) * (1.0 - cos_half), 1e-6)
                    e *= _smoothstep((cos_angle - cos_half) / blend)[:, None]
            lit = cos_s > 0
            if lights.cast_shadow[i] and lit.any():
                idx = np.nonzero(lit)[0]
                origin = _offset(p[idx], n[idx])
                blocked = self.occluded(origin, to_light[idx], np.minimum(dist[idx], 1e30) * (1 - 1e-4))
                lit[idx[blocked]] = False
            total += np.where(lit[:, None], e, 0.0)
        return total

    def render(self, camera, max_depth: int = 4) -> np.ndarray:
        """(H, W, 3) float64 linear radiance, row 0 at the bottom."""
        origins, dirs = camera.pixel_rays()
        h, w = origins.shape[:2]
        image = np.zeros((h * w, 3))
        ray_o = origins.reshape(-1, 3).astype(np.float64)
        ray_d = dirs.reshape(-1, 3).astype(np.float64)
        pixel = np.arange(h * w)
        weight = np.ones((h * w, 3))
        depth = np.zeros(h * w, np.int64)
        last_depth = max_depth + min(max_depth, 1)
        while len(pixel):
            t, tri, u, v, ng = self.intersect(ray_o, ray_d)
            miss = tri < 0
            np.add.at(image, pixel[miss], weight[miss] * self.sky)
            hit = ~miss
            pixel, ray_o, ray_d, weight, depth = (a[hit] for a in (pixel, ray_o, ray_d, weight, depth))
            t, tri, u, v, ng = (a[hit] for a in (t, tri, u, v, ng))
            if not len(pixel):
                break
            p = ray_o + ray_d * t[:, None]
            nrm = self.normals[tri]
            shading = (1 - u - v)[:, None] * nrm[:, 0] + u[:, None] * nrm[:, 1] + v[:, None] * nrm[:, 2]
            n = _normalize(shading, _normalize(ng, -ray_d))
            mat = self.material_ids[tri]
            albedo = self.base[mat]
            refl, trans = self.reflectivity[mat], self.transmission[mat]
            diffuse = np.maximum(0.0, 1.0 - refl - trans)
            entering = (n * ray_d).sum(-1) < 0
            n_f = np.where(entering[:, None], n, -n)
            local = self.emission[mat].copy()
            lit = diffuse > 0
            if lit.any():
                # Lamps with shadow rays, and the uniform sky over the whole hemisphere
                # (irradiance pi L, unoccluded: the tracer's hits take no ambient occlusion).
                local[lit] += (diffuse[lit, None] * albedo[lit] / np.pi
                               * (self.direct_irradiance(p[lit], n_f[lit]) + np.pi * self.sky))
            np.add.at(image, pixel, weight * local)
            # Specular lobes (shading.glsl specular_split).
            cos_i = np.clip(-(ray_d * n_f).sum(-1), 0.0, 1.0)
            reflect_dir = ray_d + 2.0 * cos_i[:, None] * n_f
            eta = np.where(entering, self.ior[mat], 1.0 / self.ior[mat])
            f = np.where(trans > 0, fresnel_dielectric(cos_i, eta), 0.0)
            reflect_w = refl[:, None] * albedo + (trans * f)[:, None]
            k = 1.0 - (1.0 / eta) ** 2 * (1.0 - cos_i**2)
            refract_ok = (trans > 0) & (f < 1.0) & (k >= 0)
            refract_dir = (ray_d / eta[:, None]
                           + ((cos_i / eta) - np.sqrt(np.maximum(k, 0.0)))[:, None] * n_f)
            refract_dir = _normalize(refract_dir, ray_d)
            refract_w = np.where(refract_ok[:, None], (trans * (1 - f))[:, None] * albedo, 0.0)
            child = depth + 1
            if (depth > max_depth).all():
                break  # rays past the limit spawn none
            new = []
            for dir_, w_, towards in ((reflect_dir, reflect_w, n_f), (refract_dir, refract_w, -n_f)):
                # Rays one past the depth limit are traced and shaded, and spawn none; with
                # max_depth 0 there are no secondary rays and they see the sky
                # (hybrid_trace.comp.glsl push).
                cut = (child > last_depth) & ((weight * w_).max(-1) > 0.0)
                np.add.at(image, pixel[cut], (weight * w_)[cut] * self.sky)
                keep = (child <= last_depth) & ((weight * w_).max(-1) > 0.0)
                if keep.any():
                    new.append((pixel[keep], _offset(p[keep], towards[keep]), dir_[keep],
                                (weight * w_)[keep], child[keep]))
            if not new:
                break
            pixel, ray_o, ray_d, weight, depth = (np.concatenate(parts) for parts in zip(*new))
        return image.reshape(h, w, 3)


def to_srgb_ldr(linear: np.ndarray) -> np.ndarray:
    """Clamp linear radiance to [0, 1] and encode it as sRGB (FLIP's LDR input)."""
    c = np.clip(np.nan_to_num(np.asarray(linear, np.float64)[..., :3], nan=0.0), 0.0, 1.0)
    srgb = np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1 / 2.4) - 0.055)
    return srgb.astype(np.float32)


def flip_mean(reference_linear: np.ndarray, test_linear: np.ndarray) -> float:
    """Mean LDR FLIP error between two linear images (top row first for FLIP)."""
    import flip_evaluator as flip

    ref = np.ascontiguousarray(to_srgb_ldr(reference_linear)[::-1])
    test = np.ascontiguousarray(to_srgb_ldr(test_linear)[::-1])
    _, mean, _ = flip.evaluate(ref, test, "LDR", applyMagma=False)
    return float(mean)
