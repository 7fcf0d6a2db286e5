# SPDX-License-Identifier: GPL-3.0-or-later
"""Voronoi Texture (gpu_shaders/include/nodes/tex_voronoi.glsl) against Cycles, for every
feature, dimension and distance metric Blender offers, at three scales and two detail levels
(one of them fractional, with Normalize on).

Each Cycles render shows one node and packs three of its outputs into its three channels, so
one render (and one evaluation of the node) checks three images. The GLSL side runs one
generic probe whose settings come from a table indexed by the point's w: the codes are
run-time values there, as in the node interpreter.

Distance (and all of Smooth F1, a smooth blend of cells) is continuous, so every pixel is
held to the issue's bar: mean absolute difference <= 1 % and 99th percentile <= 2 % of the
value range. F1's and F2's Color, Position and W, and Radius, jump at cell borders, where the last float bit of Cycles' ray-plane coordinates can put a pixel into
the neighbouring cell: such a pixel is counted as flipped, their fraction is bounded, and the
rest are held to the same bar."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from node_oracle import cycles_emission_plane, glsl_probe, plane_points

# The int codes of tex_voronoi.glsl, by Blender's enum strings.
VORONOI_CODES = {
    "voronoi_dimensions": {"1D": 1, "2D": 2, "3D": 3, "4D": 4},
    "feature": {"F1": 0, "F2": 1, "SMOOTH_F1": 2, "DISTANCE_TO_EDGE": 3, "N_SPHERE_RADIUS": 4},
    "distance": {"EUCLIDEAN": 0, "MANHATTAN": 1, "CHEBYCHEV": 2, "MINKOWSKI": 3},
}

SIZE, EXTENT = 48, 1.0
SCALES = (2.5, 5.0, 11.3)
# (detail, normalize): the default single octave, and a fractional octave sum.
DETAILS = ((0.0, False), (2.5, True))
ROUGHNESS, LACUNARITY, SMOOTHNESS, EXPONENT, RANDOMNESS = 0.6, 2.1, 0.7, 1.5, 0.9
MEAN_BAR, P99_BAR = 0.01, 0.02
# A pixel whose discontinuous output differs by more than this share of the range is taken
# to lie in another cell than Cycles' pixel (a cell-border flip).
FLIP_THRESHOLD = 0.05
# Bound on the share of flipped pixels per image (at 48x48, 0.5 % is 11 pixels): flips happen
# only where a pixel centre lies within float noise of a cell border.
FLIP_BOUND = 0.005

DIMENSIONS = ("1D", "2D", "3D", "4D")
FEATURES = ("F1", "F2", "SMOOTH_F1", "DISTANCE_TO_EDGE", "N_SPHERE_RADIUS")
METRICS = ("EUCLIDEAN", "MANHATTAN", "CHEBYCHEV", "MINKOWSKI")

# Each Cycles render shows one node (one scale, so Cycles evaluates it once) and packs three of
# its outputs: red the Distance (Radius for N-Sphere Radius), green one component of Color,
# blue one component of the position (Position, or W where a dimension has it): the
# component is the scale's index, so three scales cover every component.
_POSITION_COMPONENTS = {  # per scale index: Position component 0-2, "W", or "z+W"
    "1D": ("W", "W", "W"), "2D": (0, 1, 0), "3D": (0, 1, 2), "4D": (0, 1, "z+W")}


def _metrics(feature: str, dimensions: str) -> tuple[str, ...]:
    """The metrics Blender offers: 1D, Distance to Edge and N-Sphere Radius have none."""
    if dimensions == "1D" or feature in ("DISTANCE_TO_EDGE", "N_SPHERE_RADIUS"):
        return ("EUCLIDEAN",)
    return METRICS


def _details(feature: str) -> tuple[tuple[float, bool], ...]:
    """N-Sphere Radius has no octave inputs in Blender."""
    return DETAILS[:1] if feature == "N_SPHERE_RADIUS" else DETAILS


def _channels(feature: str) -> tuple[bool, ...]:
    """Which channels a feature fills; Distance to Edge and N-Sphere Radius have only red."""
    return (True, False, False) if feature in ("DISTANCE_TO_EDGE", "N_SPHERE_RADIUS") else (True,) * 3


def _size(feature: str, dimensions: str) -> int:
    """Smooth F1 in 4D searches 625 cells per octave: a smaller image keeps the run short."""
    return 32 if (feature, dimensions) == ("SMOOTH_F1", "4D") else SIZE


# Every configuration of the whole module, in one table, so the probe is compiled once.
_CONFIGS = [
    (feature, dimensions, metric, detail, normalize, scale)
    for feature in FEATURES for dimensions in DIMENSIONS
    for metric in _metrics(feature, dimensions)
    for detail, normalize in _details(feature) for scale in SCALES
]
_INDEX = {config: i for i, config in enumerate(_CONFIGS)}


def _probe_body() -> str:
    codes = ", ".join(
        f"ivec4({VORONOI_CODES['voronoi_dimensions'][d]}, {VORONOI_CODES['feature'][f]}, "
        f"{VORONOI_CODES['distance'][m]}, {int(n)})" for f, d, m, _, n, _ in _CONFIGS)
    params = ", ".join(f"vec2({s!r}, {detail!r})" for _, _, _, detail, _, s in _CONFIGS)
    n = len(_CONFIGS)
    return f"""
    const ivec4 codes[{n}] = ivec4[{n}]({codes});
    const vec2 params[{n}] = vec2[{n}]({params});
    // w = 4 * configuration + scale index k: the channel the render shows this scale in.
    int index = int(p.w);
    int k = index % 4;
    ivec4 c = codes[index / 4];
    vec2 sd = params[index / 4];
    float distance_out, w_out, radius_out; vec3 color_out, position_out;
    node_tex_voronoi(c.x, c.y, c.z, c.w, p.xyz, p.x + p.y, sd.x, sd.y, {ROUGHNESS!r},
                     {LACUNARITY!r}, {SMOOTHNESS!r}, {EXPONENT!r}, {RANDOMNESS!r},
                     distance_out, color_out, position_out, w_out, radius_out);
    float red = c.y == {VORONOI_CODES["feature"]["N_SPHERE_RADIUS"]} ? radius_out : distance_out;
    float blue = c.x == 1 ? w_out
               : c.x == 2 ? position_out[k % 2]
               : c.x == 4 && k == 2 ? position_out.z + w_out : position_out[k];
    return vec4(red, color_out[k], blue, 0.0);"""


def _socket(sockets, identifier: str):
    return next(s for s in sockets if s.identifier == identifier)


def _voronoi(nodes, links, vector, feature, dimensions, metric, detail, normalize, scale):
    """One Voronoi Texture node; W = x + y, so 1D and 4D vary over the plane."""
    node = nodes.new("ShaderNodeTexVoronoi")
    links.new(vector, _socket(node.inputs, "Vector"))
    split = nodes.new("ShaderNodeSeparateXYZ")
    links.new(vector, split.inputs[0])
    w = nodes.new("ShaderNodeMath")
    w.operation = "ADD"
    links.new(split.outputs["X"], w.inputs[0])
    links.new(split.outputs["Y"], w.inputs[1])
    links.new(w.outputs[0], _socket(node.inputs, "W"))
    for identifier, value in (("Scale", scale), ("Detail", detail), ("Roughness", ROUGHNESS),
                              ("Lacunarity", LACUNARITY), ("Smoothness", SMOOTHNESS),
                              ("Exponent", EXPONENT), ("Randomness", RANDOMNESS)):
        _socket(node.inputs, identifier).default_value = value
    node.voronoi_dimensions = dimensions  # after linking: hidden sockets cannot be looked up
    node.feature = feature
    node.distance = metric
    node.normalize = normalize
    return node


def _cycles_render(tmp_path, k, feature, dimensions, metric, detail, normalize) -> np.ndarray:
    """Cycles' packed image of one configuration at scale index k."""
    def build(nodes, links, vector):
        node = _voronoi(nodes, links, vector, feature, dimensions, metric, detail, normalize, SCALES[k])
        combine = nodes.new("ShaderNodeCombineXYZ")
        red = "Radius" if feature == "N_SPHERE_RADIUS" else "Distance"
        links.new(_socket(node.outputs, red), combine.inputs[0])
        if _channels(feature)[1]:
            color = nodes.new("ShaderNodeSeparateColor")
            links.new(_socket(node.outputs, "Color"), color.inputs[0])
            links.new(color.outputs[k], combine.inputs[1])
            component = _POSITION_COMPONENTS[dimensions][k]
            if component == "W":
                blue = _socket(node.outputs, "W")
            else:
                position = nodes.new("ShaderNodeSeparateXYZ")
                links.new(_socket(node.outputs, "Position"), position.inputs[0])
                blue = position.outputs[2 if component == "z+W" else component]
                if component == "z+W":
                    add = nodes.new("ShaderNodeMath")
                    add.operation = "ADD"
                    links.new(blue, add.inputs[0])
                    links.new(_socket(node.outputs, "W"), add.inputs[1])
                    blue = add.outputs[0]
            links.new(blue, combine.inputs[2])
        return combine.outputs[0]

    return cycles_emission_plane(build, tmp_path, _size(feature, dimensions), EXTENT)


def _glsl_renders(ctx, feature, dimensions, metric, detail, normalize) -> np.ndarray:
    """Our packed images of one configuration at the three scales, from one probe run."""
    size = _size(feature, dimensions)
    batch = np.empty((len(SCALES), size, size, 4), np.float32)
    batch[..., :3] = plane_points(size, EXTENT)
    for k, scale in enumerate(SCALES):
        batch[k, ..., 3] = 4 * _INDEX[(feature, dimensions, metric, detail, normalize, scale)] + k
    return glsl_probe(ctx, ["include/nodes/tex_voronoi.glsl"], _probe_body(), batch)[..., :3]


def _measure(ours: np.ndarray, cycles: np.ndarray, discontinuous: bool) -> dict[str, float]:
    """Error relative to the value range of Cycles' image; a discontinuous output's pixels
    beyond FLIP_THRESHOLD count as flipped and are left out of mean and p99."""
    theirs = cycles.astype(np.float64)
    span = max(float(theirs.max() - theirs.min()), 1e-6)
    error = np.abs(ours - theirs).ravel() / span
    kept = error[error <= FLIP_THRESHOLD] if discontinuous else error
    if kept.size == 0:
        return {"mean": 1.0, "p99": 1.0, "flipped": 1.0}
    return {"mean": float(kept.mean()), "p99": float(np.percentile(kept, 99)),
            "flipped": 1.0 - kept.size / error.size}


_CHANNEL_NAMES = ("distance", "color", "position")


@pytest.mark.parametrize("feature,dimensions", list(itertools.product(FEATURES, DIMENSIONS)))
def test_voronoi_equals_cycles_at_three_scales_and_two_detail_levels(ctx, tmp_path, feature, dimensions):
    failures, report = [], []
    channels = _channels(feature)
    for metric in _metrics(feature, dimensions):
        for detail, normalize in _details(feature):
            ours = _glsl_renders(ctx, feature, dimensions, metric, detail, normalize)
            for k, scale in enumerate(SCALES):
                cycles = _cycles_render(tmp_path, k, feature, dimensions, metric, detail, normalize)
                for channel in range(3):
                    if not channels[channel]:
                        continue
                    theirs = cycles[..., channel]
                    # Not a constant image: the texture varies over the plane at every scale.
                    assert np.ptp(theirs) > 1e-3, (metric, detail, scale, channel)
                    # Radius, and F1's / F2's Color and position are constant per cell.
                    discontinuous = ((channel > 0 and feature != "SMOOTH_F1")
                                     or feature == "N_SPHERE_RADIUS")
                    m = _measure(ours[k, ..., channel], theirs, discontinuous)
                    line = (f"{feature} {dimensions} {metric} detail={detail} scale={scale} {_CHANNEL_NAMES[channel]}: "
                            f"mean {m['mean']:.4%} p99 {m['p99']:.4%} flipped {m['flipped']:.3%}")
                    report.append(line)
                    if m["mean"] > MEAN_BAR or m["p99"] > P99_BAR or m["flipped"] > FLIP_BOUND:
                        failures.append(line)
    print("\n".join(report))
    assert not failures, "\n".join(failures)


# Settings at the ends of their ranges, where Cycles takes a particular path: all 16 octaves
# at full roughness, Lacunarity 0 (every octave after the first samples the origin's cell, as
# Cycles does; not the single octave), Smoothness 0 (Smooth F1 falls back to F1), and
# Randomness 0 (a regular grid). (feature, detail, roughness, lacunarity, smoothness,
# randomness, output).
_EDGE_SETTINGS = [
    ("F1", 15.0, 1.0, 2.0, 1.0, 1.0, "Distance"),
    ("F1", 2.0, 0.5, 0.0, 1.0, 1.0, "Color"),
    ("SMOOTH_F1", 1.0, 0.5, 2.0, 0.0, 1.0, "Color"),
    ("F2", 1.5, 0.5, 2.0, 1.0, 0.0, "Distance"),
]


@pytest.mark.parametrize("feature,detail,roughness,lacunarity,smoothness,randomness,output", _EDGE_SETTINGS)
def test_voronoi_equals_cycles_at_the_ends_of_its_settings(ctx, tmp_path, feature, detail, roughness,
                                                           lacunarity, smoothness, randomness, output):
    size = 32

    def build(nodes, links, vector):
        node = nodes.new("ShaderNodeTexVoronoi")
        links.new(vector, _socket(node.inputs, "Vector"))
        for identifier, value in (("Detail", detail), ("Roughness", roughness), ("Lacunarity", lacunarity),
                                  ("Smoothness", smoothness), ("Randomness", randomness)):
            _socket(node.inputs, identifier).default_value = value
        node.feature = feature
        return _socket(node.outputs, output)

    cycles = cycles_emission_plane(build, tmp_path, size, EXTENT)
    shown = "vec3(distance_out)" if output == "Distance" else "color_out"
    ours = glsl_probe(ctx, ["include/nodes/tex_voronoi.glsl"], f"""
        float distance_out, w_out, radius_out; vec3 color_out, position_out;
        node_tex_voronoi(3, {VORONOI_CODES['feature'][feature]}, 0, 0, p.xyz, 0.0, 5.0, {detail!r},
                         {roughness!r}, {lacunarity!r}, {smoothness!r}, 0.5, {randomness!r},
                         distance_out, color_out, position_out, w_out, radius_out);
        return vec4({shown}, 0.0);""", plane_points(size, EXTENT))[..., :3]
    assert np.ptp(cycles) > 1e-3
    m = _measure(ours, cycles, discontinuous=output == "Color" and feature == "F1")
    print(f"{feature} detail={detail} lacunarity={lacunarity} smoothness={smoothness} "
          f"randomness={randomness} {output}: mean {m['mean']:.4%} p99 {m['p99']:.4%} flipped {m['flipped']:.3%}")
    assert m["mean"] <= MEAN_BAR and m["p99"] <= P99_BAR and m["flipped"] <= FLIP_BOUND, m
