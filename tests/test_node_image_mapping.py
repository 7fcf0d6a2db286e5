# SPDX-License-Identifier: GPL-3.0-or-later
"""Image Texture's coordinate work (gpu_shaders/include/nodes/tex_image_mapping.glsl) against
Cycles: a small image of known, distinct texels is rendered by Cycles through each projection
and extension, and compared with the GLSL mapping's texels and weights read back and looked
up in numpy. The fetch is the interpreter's job; what is proven here is that the mapping picks
the texels (and, for Linear and Box, the weights) that Cycles picks.

The vector is (x, y, x * y) so Sphere, Tube and Box see all three coordinates. For Box the
plane gets custom normals leaning every way (negative sides included), so the shading normal
sweeps through single-side, two-side and three-side zones; Cycles renders that normal too
(Geometry > Normal), and it feeds the GLSL weights. A pixel centred within float rounding of a
texel edge or a Box zone edge may read the neighbouring texel in Cycles (its coordinates come
from a ray-plane hit): such pixels are counted and bounded, not hidden in a tolerance."""
from __future__ import annotations

import numpy as np
import pytest

from node_oracle import cycles_emission_plane, glsl_probe, plane_points
from pattern_compare import difference, with_product_z

IMAGE_PROJECTION_CODES = {"FLAT": 0, "BOX": 1, "SPHERE": 2, "TUBE": 3}
IMAGE_EXTENSION_CODES = {"REPEAT": 0, "EXTEND": 1, "CLIP": 2, "MIRROR": 3}
IMAGE_INTERPOLATION_CODES = {"Linear": 0, "Closest": 1, "Cubic": 2, "Smart": 3}

SIZE = 48
WIDTH, HEIGHT = 5, 3  # not square, so a swapped axis shows
MAX_FLIPPED = 0.01
# Custom corner normals of the plane for Box, corners (-,-), (+,-), (+,+), (-,+).
BOX_NORMALS = [(-0.9, 0.2, -0.4), (0.3, -0.9, 0.3), (0.8, 0.4, 0.2), (0.1, 0.6, -0.8)]
INCLUDE = ["include/nodes/tex_image_mapping.glsl"]


def _texels() -> np.ndarray:
    """(HEIGHT, WIDTH, 4) distinct colours, alpha 1; row 0 is the image's bottom row."""
    rng = np.random.default_rng(38)
    pixels = np.ones((HEIGHT, WIDTH, 4), np.float32)
    pixels[..., :3] = rng.random((HEIGHT, WIDTH, 3), dtype=np.float32)
    return pixels


def _lean_normals(nodes) -> None:
    import bpy
    mesh = bpy.data.meshes["plane"]  # the oracle's plane; its normals only matter for Box
    mesh.normals_split_custom_set([tuple(np.asarray(n) / np.linalg.norm(n)) for n in BOX_NORMALS])
    mesh.shade_smooth()


def _image_node(projection: str, extension: str, interpolation: str, blend: float):
    def build(nodes, links, vector):
        import bpy
        if projection == "BOX":
            _lean_normals(nodes)
        image = bpy.data.images.new("texels", WIDTH, HEIGHT, alpha=True, float_buffer=True)
        image.colorspace_settings.name = "Non-Color"
        image.pixels.foreach_set(_texels().ravel())
        image.pack()
        node = nodes.new("ShaderNodeTexImage")
        node.image = image
        node.projection, node.extension, node.interpolation = projection, extension, interpolation
        node.projection_blend = blend
        links.new(with_product_z(nodes, links, vector), node.inputs["Vector"])
        return node.outputs["Color"]
    return build


def _shading_normals(tmp_path, extent: float) -> np.ndarray:
    def build(nodes, links, vector):
        _lean_normals(nodes)
        return nodes.new("ShaderNodeNewGeometry").outputs["Normal"]
    return cycles_emission_plane(build, tmp_path, SIZE, extent)


def _ours(ctx, projection: str, extension: str, interpolation: str, blend: float,
          points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """The GLSL mapping's result, fetched in numpy: (SIZE, SIZE, 3)."""
    code, ext = IMAGE_PROJECTION_CODES[projection], IMAGE_EXTENSION_CODES[extension]
    # Box weights from the normal alone; the side images from the point and the normal's signs
    # (all they use of it), so each probe gets the four floats it needs.
    side_weights = glsl_probe(ctx, INCLUDE, f"""
        vec2 uv0, uv1, uv2; vec3 w;
        node_tex_image_project({code}, vec3(0.0), p.xyz, {blend:.9g}, uv0, uv1, uv2, w);
        return vec4(w, 0.0);""", normals)[..., :3]
    signs = (normals < 0) @ np.array([1, 2, 4])
    located = np.concatenate([points[..., :2], np.zeros_like(points[..., :1]), signs[..., None]], -1)
    pixels = _texels()[..., :3].astype(np.float64)
    result = np.zeros((*points.shape[:2], 3))
    size = f"ivec2({WIDTH}, {HEIGHT})"
    for side in range(3 if projection == "BOX" else 1):  # the others weigh (1, 0, 0)
        uv = f"""
            int s = int(p.w);
            vec3 n = vec3((s & 1) != 0 ? -1.0 : 1.0, (s & 2) != 0 ? -1.0 : 1.0, (s & 4) != 0 ? -1.0 : 1.0);
            vec2 uvs[3]; vec3 w;
            node_tex_image_project({code}, vec3(p.xy, p.x * p.y), n, {blend:.9g}, uvs[0], uvs[1], uvs[2], w);
            vec2 uv = uvs[{side}];"""
        if interpolation == "Closest":
            got = glsl_probe(ctx, INCLUDE, uv + f"""
                ivec2 texel; vec2 centre;
                bool inside = node_tex_image_closest({ext}, uv, {size}, texel, centre);
                return vec4(vec2(texel), inside ? 1.0 : 0.0, 0.0);""", located)
            texel = got[..., :2].astype(int)
            value = pixels[texel[..., 1], texel[..., 0]] * got[..., 2:3]
        elif interpolation in ("Cubic", "Smart"):
            columns, rows, column_weights, row_weights = (glsl_probe(ctx, INCLUDE, uv + f"""
                ivec4 xs, ys; vec4 wx, wy;
                node_tex_image_cubic({ext}, uv, {size}, xs, ys, wx, wy);
                return vec4({name});""", located) for name in ("xs", "ys", "wx", "wy"))
            columns, rows = columns.astype(int), rows.astype(int)
            value = sum(column_weights[..., i:i + 1] * row_weights[..., j:j + 1]
                        * pixels[rows[..., j], columns[..., i]] for i in range(4) for j in range(4))
        else:
            corners = glsl_probe(ctx, INCLUDE, uv + f"""
                ivec2 lo, hi;
                node_tex_image_linear({ext}, uv, {size}, lo, hi);
                return vec4(lo, hi);""", located).astype(int)
            taps = glsl_probe(ctx, INCLUDE, uv + f"""
                ivec2 lo, hi;
                return node_tex_image_linear({ext}, uv, {size}, lo, hi);""", located)
            lo_x, lo_y, hi_x, hi_y = (corners[..., k] for k in range(4))
            value = sum(taps[..., k:k + 1] * pixels[y, x] for k, (x, y) in
                        enumerate([(lo_x, lo_y), (hi_x, lo_y), (lo_x, hi_y), (hi_x, hi_y)]))
        result += side_weights[..., side:side + 1] * value
    return result


def _compare(ctx, tmp_path, projection, extension, interpolation, extent, blend=0.3):
    points = plane_points(SIZE, extent)
    normals = (_shading_normals(tmp_path, extent) if projection == "BOX"
               else np.broadcast_to(np.float32([0, 0, 1]), points.shape).copy())
    ours = _ours(ctx, projection, extension, interpolation, blend, points, normals)
    cycles = cycles_emission_plane(_image_node(projection, extension, interpolation, blend),
                                   tmp_path, SIZE, extent)
    d = difference(ours, cycles, value_range=1.0)
    print(f"image {projection} {extension} {interpolation} extent {extent} blend {blend}: {d}")
    case = f"{projection} {extension} {interpolation} extent {extent} blend {blend}"
    assert d.flipped <= MAX_FLIPPED, f"{case}: {d}"
    assert d.mean <= 0.01 and d.p99 <= 0.02, f"{case}: {d}"
    assert len(np.unique(cycles.reshape(-1, 3), axis=0)) >= 6  # many texels shown, not one


@pytest.mark.parametrize("projection", list(IMAGE_PROJECTION_CODES))
def test_closest_texels_match_cycles_for_every_extension_at_three_scales(addon, ctx, tmp_path, projection):
    for extension in IMAGE_EXTENSION_CODES:
        for extent in (0.8, 1.5, 3.0):
            _compare(ctx, tmp_path, projection, extension, "Closest", extent)


@pytest.mark.parametrize("projection", list(IMAGE_PROJECTION_CODES))
def test_linear_taps_and_weights_match_cycles_for_every_extension(addon, ctx, tmp_path, projection):
    for extension in IMAGE_EXTENSION_CODES:
        _compare(ctx, tmp_path, projection, extension, "Linear", 1.5)


@pytest.mark.parametrize("interpolation", ["Cubic", "Smart"])
def test_cubic_taps_and_weights_match_cycles_for_every_extension(addon, ctx, tmp_path, interpolation):
    for extension in IMAGE_EXTENSION_CODES:
        for projection in ("FLAT", "SPHERE"):
            _compare(ctx, tmp_path, projection, extension, interpolation, 1.5)


def test_box_blend_extremes_match_cycles(addon, ctx, tmp_path):
    for blend in (0.0, 1.0):
        _compare(ctx, tmp_path, "BOX", "REPEAT", "Linear", 1.5, blend)
