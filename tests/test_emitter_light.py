# SPDX-License-Identifier: GPL-3.0-or-later
"""Emissive triangles as lights (gpu_shaders/include/emitter_light.glsl): the next-event
estimate ``emitter_irradiance`` against closed forms and an Embree visibility oracle, through
the probe kernel of tests/emitter_probe.py (the frame's upload, transform, BVH and emitter
table)."""
from __future__ import annotations

import numpy as np
import pytest
from embreex import rtcore_scene as rtcs
from embreex.mesh_construction import TriangleMesh

from emitter_probe import EmitterProbe
from hybrid_engine.scene.data import MaterialTable, SceneData
from hybrid_engine.scene.geometry import Geometry

RADIANCE = 3.0
HEIGHT = 2.0  # the panel's plane, z
HALF = 0.5  # the panel's half-size: a 1 m square centred above the origin
GREY, LAMP, GLASS = 0, 1, 2
SAMPLES = 8192


def rectangle(x0: float, x1: float, y0: float, y1: float, z: float) -> np.ndarray:
    """Two triangles covering [x0, x1] x [y0, y1] at height z."""
    v = np.array([[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]], np.float32)
    return np.array([[v[0], v[1], v[2]], [v[0], v[2], v[3]]])


def panel_corners(x0=-HALF, x1=HALF, y0=-HALF, y1=HALF) -> np.ndarray:
    return np.array([[x0, y0, HEIGHT], [x1, y0, HEIGHT], [x1, y1, HEIGHT], [x0, y1, HEIGHT]], float)


def polygon_irradiance(p, n, corners, radiance: float = RADIANCE) -> float:
    """Lambert's closed form: the irradiance at p (unit normal n) from a uniformly emitting
    convex polygon wholly above p's tangent plane, L/2 sum_i theta_i (n . unit(v_i x v_i+1))."""
    v = np.asarray(corners, float) - np.asarray(p, float)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    total = 0.0
    for a, b in zip(v, np.roll(v, -1, axis=0)):
        c = np.cross(a, b)
        s = np.linalg.norm(c)
        total += np.arctan2(s, np.dot(a, b)) * np.dot(n, c / s)
    return radiance * 0.5 * abs(total)


def materials() -> MaterialTable:
    return MaterialTable.from_rows([dict(name="grey"), dict(name="lamp", emission=(RADIANCE,) * 3),
                                    dict(name="glass", transmission=0.6, ior=1.0)])


def panel_scene(*blockers: tuple[np.ndarray, int]) -> SceneData:
    objects = [(rectangle(-HALF, HALF, -HALF, HALF, HEIGHT), None, LAMP)]
    objects += [(tris, None, material) for tris, material in blockers]
    return SceneData(geometry=Geometry.from_objects(objects), materials=materials())


@pytest.fixture
def probe_of(gl):
    made = []

    def make(scene: SceneData, scan_family: str | None = None) -> EmitterProbe:
        made.append(EmitterProbe(gl, scene, scan_family))
        return made[-1]

    yield make
    for probe in made:
        probe.release()


# Below the centre at growing distances (the falloff), off the axis, and tilted receivers
# (the panel wholly above each tangent plane).
POINTS = np.array([[0, 0, 1.75], [0, 0, 1.0], [0, 0, 0], [0, 0, -3.0], [0, 0, -8.0],
                   [0.4, 0.3, 1.5], [1.5, -0.5, 0.5], [-0.7, 0.2, 1.2], [0.1, 0.1, 0.0]], np.float32)
NORMALS = np.array([[0, 0, 1], [0, 0, 1], [0, 0, 1], [0, 0, 1], [0, 0, 1],
                    [0, 0, 1], [-0.6, 0.0, 0.8], [0.3, 0.3, 0.9], [0.2, -0.4, 0.9]], np.float32)
NORMALS /= np.linalg.norm(NORMALS, axis=1, keepdims=True)


@pytest.mark.parametrize("scan_family", ["cpu", "gpu"])
def test_the_irradiance_from_a_square_panel_is_lamberts_closed_form_and_falls_off_with_distance(
        probe_of, scan_family):
    probe = probe_of(panel_scene(), scan_family)
    assert probe.table.scan_family == scan_family
    estimate, rays = probe.irradiance(POINTS, NORMALS, SAMPLES, seed=11)
    expected = np.array([polygon_irradiance(p, n, panel_corners()) for p, n in zip(POINTS, NORMALS)])
    np.testing.assert_allclose(estimate[:, 0], expected, rtol=0.03)
    assert np.array_equal(estimate[:, 0], estimate[:, 2])  # grey emission stays grey
    # The falloff along the axis: from near the panel to far, past the inverse square's reach.
    on_axis = estimate[:5, 0]
    assert (np.diff(on_axis) < 0).all() and on_axis[0] > 30 * on_axis[4]
    assert (rays == SAMPLES).all()  # one shadow ray per sample, all above the horizon


def test_emission_is_two_sided_as_cycles_emission_shader(probe_of):
    probe = probe_of(panel_scene())
    below, _ = probe.irradiance([[0.2, 0.1, 1.0]], [[0, 0, 1]], SAMPLES, seed=3)
    above, _ = probe.irradiance([[0.2, 0.1, 3.0]], [[0, 0, -1]], SAMPLES, seed=3)
    expected = polygon_irradiance([0.2, 0.1, 1.0], [0, 0, 1], panel_corners())
    np.testing.assert_allclose([below[0, 0], above[0, 0]], expected, rtol=0.03)


def test_a_surface_facing_away_from_every_emitter_gets_nothing_and_traces_nothing(probe_of):
    probe = probe_of(panel_scene())
    estimate, rays = probe.irradiance([[0, 0, 0], [0, 0, 4]], [[0, 0, -1], [0, 0, 1]], 256)
    assert (estimate == 0).all() and (rays == 0).all()


@pytest.mark.parametrize("x", [0.0, 0.2])
def test_a_blocker_hides_exactly_the_part_of_the_panel_behind_it(probe_of, x):
    # A large plane at half the height covering x < 0: from a point at x, the panel is seen
    # only where x + 2 (0 - x) < x_panel, i.e. x_panel > -x.
    blocker = rectangle(-10.0, 0.0, -10.0, 10.0, HEIGHT / 2)
    probe = probe_of(panel_scene((blocker, GREY)))
    estimate, _ = probe.irradiance([[x, 0, 0]], [[0, 0, 1]], SAMPLES, seed=5)
    expected = polygon_irradiance([x, 0, 0], [0, 0, 1], panel_corners(x0=-x))
    full = polygon_irradiance([x, 0, 0], [0, 0, 1], panel_corners())
    assert expected < 0.75 * full
    np.testing.assert_allclose(estimate[0, 0], expected, rtol=0.03)


def test_glass_between_lets_through_its_transmission(probe_of):
    probe = probe_of(panel_scene((rectangle(-10, 10, -10, 10, 1.0), GLASS)))
    estimate, _ = probe.irradiance([[0.1, 0.0, 0.0]], [[0, 0, 1]], SAMPLES, seed=9)
    expected = 0.6 * polygon_irradiance([0.1, 0, 0], [0, 0, 1], panel_corners())
    np.testing.assert_allclose(estimate[0, 0], expected, rtol=0.03)


def embree_irradiance(scene: SceneData, p: np.ndarray, n: np.ndarray, grid: int = 160) -> float:
    """The panel's irradiance at p by midpoint quadrature over a grid of its points, each
    seen or not by an Embree occlusion ray (the oracle of visibility)."""
    tris = scene.geometry.triangles.astype(np.float32)
    embree = rtcs.EmbreeScene()
    TriangleMesh(embree, tris)
    u = (np.arange(grid) + 0.5) / grid * 2 * HALF - HALF
    gx, gy = np.meshgrid(u, u)
    q = np.stack([gx.ravel(), gy.ravel(), np.full(gx.size, HEIGHT)], axis=1)
    to = q - p
    d = np.linalg.norm(to, axis=1)
    w = to / d[:, None]
    origins = (p + n * 1e-4).astype(np.float32)
    hit = embree.run(np.repeat(origins[None], len(q), 0), w.astype(np.float32), output=1)
    blocked = (hit["primID"] >= 0) & (hit["tfar"] < d * (1 - 1e-4)) & np.isin(hit["geomID"], [0]) \
        & (hit["primID"] >= 2)  # triangles 0 and 1 are the panel itself
    cos_p = np.clip(w @ n, 0, None)
    cos_l = np.abs(w[:, 2])
    area = (2 * HALF / grid) ** 2
    return float(RADIANCE * np.sum(~blocked * cos_p * cos_l / d ** 2) * area)


def test_random_blockers_hide_what_embree_finds_hidden(probe_of, rng):
    blockers = []
    for _ in range(6):
        centre = np.array([rng.uniform(-0.6, 0.6), rng.uniform(-0.6, 0.6), rng.uniform(0.5, 1.5)])
        blockers.append(((centre + rng.uniform(-0.3, 0.3, (1, 3, 3))).astype(np.float32), GREY))
    scene = panel_scene(*blockers)
    points = np.array([[0, 0, 0], [0.3, -0.2, 0.2], [-0.4, 0.4, -0.5]], float)
    normal = np.array([0, 0, 1.0])
    probe = probe_of(scene)
    estimate, _ = probe.irradiance(points, normal, 4 * SAMPLES, seed=17)
    expected = np.array([embree_irradiance(probe.scene, p, normal) for p in points])
    unblocked = np.array([polygon_irradiance(p, normal, panel_corners()) for p in points])
    assert (expected < 0.95 * unblocked).all()  # each point is partly in shadow
    np.testing.assert_allclose(estimate[:, 0], expected, rtol=0.03)


def test_with_no_emitter_the_estimate_is_zero_and_traces_nothing(probe_of):
    scene = SceneData(geometry=Geometry.from_objects([(rectangle(-1, 1, -1, 1, 2), None, 0)]),
                      materials=materials())
    probe = probe_of(scene)
    assert probe.table.count == 0 and probe.table.stats.gpu_steps == 0
    estimate, rays = probe.irradiance([[0, 0, 0]], [[0, 0, 1]], 64)
    assert (estimate == 0).all() and (rays == 0).all()
    index, probability = probe.picks(16)
    assert (index == -1).all() and (probability == 0).all()


def test_an_emission_texture_is_read_at_the_sampled_point(probe_of):
    # The panel's texture is black on its left half (u < 0.5, x < 0), white on its right.
    image = np.zeros((64, 64, 4), np.float32)
    image[:, 32:, :3] = 1.0
    image[..., 3] = 1.0
    tris = rectangle(-HALF, HALF, -HALF, HALF, HEIGHT)
    uvs = (tris[:, :, :2] + HALF) / (2 * HALF)
    geometry = Geometry.from_objects([(tris, None, 1)])
    geometry.uvs = uvs.astype(np.float32)
    table = MaterialTable.from_rows([dict(name="grey"), dict(name="screen", emission=(RADIANCE,) * 3,
                                                             emission_texture=image)])
    probe = probe_of(SceneData(geometry=geometry, materials=table))
    estimate, _ = probe.irradiance([[0, 0, 0], [0.3, 0, 0.5]], [[0, 0, 1]], SAMPLES, seed=21)
    expected = [polygon_irradiance(p, [0, 0, 1], panel_corners(x0=0.0)) for p in ([0, 0, 0], [0.3, 0, 0.5])]
    np.testing.assert_allclose(estimate[:, 0], expected, rtol=0.04)


def test_the_cdf_picks_each_triangle_in_proportion_to_its_power(probe_of):
    # Panels of different sizes and strengths: powers spread over two orders of magnitude.
    table = MaterialTable.from_rows([dict(name="grey"), dict(name="a", emission=(1.0, 1.0, 1.0)),
                                     dict(name="b", emission=(8.0, 2.0, 0.5)), dict(name="c", emission=(0, 0, 0.3))])
    objects = [(rectangle(0, 1, 0, 1, 0), None, 1), (rectangle(2, 4, 0, 1, 0), None, 2),
               (rectangle(5, 5.3, 0, 0.3, 0), None, 2), (rectangle(6, 9, 0, 3, 0), None, 3),
               (rectangle(0, 1, 5, 6, 0), None, 0)]
    probe = probe_of(SceneData(geometry=Geometry.from_objects(objects), materials=table))
    emission = table.emission.astype(np.float64) @ np.array([0.2126, 0.7152, 0.0722])
    area = np.repeat([0.5, 1.0, 0.045, 4.5], 2)
    power = area * np.repeat(emission[[1, 2, 2, 3]], 2)
    share = power / power.sum()
    draws = 200_000
    index, probability = probe.picks(draws, seed=23)
    assert probe.table.count == 8 and index.min() >= 0 and index.max() < 8
    counts = np.bincount(index, minlength=8)
    sigma = np.sqrt(draws * share * (1 - share))
    assert (np.abs(counts - draws * share) < 5 * sigma).all(), (counts, draws * share)
    # Each pick reports its own share (the estimate divides by it).
    np.testing.assert_allclose(probability, share[index], rtol=1e-3)
