# SPDX-License-Identifier: GPL-3.0-or-later
"""Image textures (hybrid_engine/passes/scene_upload/textures.py, gpu_shaders/include/textures.glsl) in the three
places a surface is shaded: the primary G-buffer (paper §3.1), the cube-map faces (§3.2,
whose texels keep the UV that the tracer samples at cube-map hits) and the tracer's BVH
hits (§3.4).

The oracle is a numpy bilinear lookup with repeat wrapping written here, fed with UVs that
the tests compute analytically from each pixel's ray and the planes' known UV mapping; it
shares no code with the engine beyond ``Camera.pixel_rays``. The textures are random
per-texel colours ("checkers" of random squares), so that sampling a neighbouring texel, a
flipped row order or an unwrapped coordinate shows as a large error.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import REPO_ROOT, save_failure_images
from hybrid_engine import Camera, Geometry, Lights, MaterialTable, RenderSettings, SceneData, Sky
from hybrid_engine.scene.camera import look_at
from hybrid_engine.passes.cube_map.cube_map import CubeMapPass
from hybrid_engine.passes.scene_upload.scene_buffers import GPUScene
from hybrid_engine.passes.gbuffer.gbuffer import GBufferPass
from hybrid_engine.scene.data import MATERIAL_DTYPE
from hybrid_engine.scene.arrays import SceneDataError
from hybrid_engine.passes.scene_upload.textures import (
    HALF_MAX,
    GPUTextures,
    TextureLimitError,
    layer_size,
    pack_layers,
    pixel_footprint,
    resample,
    srgb_to_linear,
)
from uv_rows_reference import TRIANGLE_UV_DTYPE
from scenes_analytic import ray_plane_z

# GPUs filter with a fixed-point sub-texel weight (8 bits on current hardware and on
# llvmpipe), so a bilinear sample may differ from the exact one by contrast / 256.
SUBTEXEL_STEPS = 256
# Texels and albedo are stored as half floats: 11 significant bits.
HALF_RTOL = 2.0**-10


def texel_tolerance(texture: np.ndarray, factor: float = 1.0) -> float:
    """Allowed |GPU - exact| for a bilinear sample of ``texture`` times ``factor``."""
    contrast = float(texture[..., :3].max() - texture[..., :3].min())
    return factor * (contrast / SUBTEXEL_STEPS + HALF_RTOL * float(np.abs(texture).max())) + 1e-5


def bilinear_repeat(texture: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """The exact bilinear sample of ``texture`` (row 0 = v 0) at ``uv`` (..., 2), repeat wrap."""
    h, w = texture.shape[:2]
    x = uv[..., 0] * w - 0.5
    y = uv[..., 1] * h - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    x0, y0 = x0.astype(np.int64), y0.astype(np.int64)
    xs0, xs1 = np.mod(x0, w), np.mod(x0 + 1, w)
    ys0, ys1 = np.mod(y0, h), np.mod(y0 + 1, h)
    return ((1 - fx) * (1 - fy) * texture[ys0, xs0] + fx * (1 - fy) * texture[ys0, xs1]
            + (1 - fx) * fy * texture[ys1, xs0] + fx * fy * texture[ys1, xs1])


def random_checker(rng, size=(8, 8)) -> np.ndarray:
    """(H, W, 4) float32: a random colour per texel (alpha 1)."""
    tex = np.ones((*size, 4), np.float32)
    tex[..., :3] = rng.uniform(0.05, 1.0, (*size, 3))
    return tex


def binary_checker(size: int) -> np.ndarray:
    """A size x size black/white checker of single texels (mean 0.5 at every 2x2 block)."""
    i, j = np.indices((size, size))
    tex = np.ones((size, size, 4), np.float32)
    tex[..., :3] = ((i + j) % 2)[..., None]
    return tex


def textured_quad(corner, edge_u, edge_v, uv0, uv_span):
    """Two triangles of the quad corner + s*edge_u + t*edge_v (s, t in [0, 1]), with
    uv = uv0 + (s, t) * uv_span; returns (triangles, uvs)."""
    c, eu, ev = (np.asarray(a, np.float64) for a in (corner, edge_u, edge_v))
    st = np.array([[[0, 0], [1, 0], [1, 1]], [[0, 0], [1, 1], [0, 1]]], np.float64)
    tris = c + st[..., :1] * eu + st[..., 1:] * ev
    uvs = np.asarray(uv0, np.float64) + st * np.asarray(uv_span, np.float64)
    return tris.astype(np.float32), uvs.astype(np.float32)


def scene_of(quads, rows, textures, lights=(), sky=(0.0, 0.0, 0.0)) -> SceneData:
    """quads: [(triangles, uvs, material)]."""
    geo = Geometry.from_objects([(t, None, m) for t, _, m in quads])
    geo = Geometry(geo.triangles, geo.normals, geo.material_ids, geo.object_ranges, geo.object_bounds,
                   geo.object_names, uvs=np.concatenate([uv for _, uv, _ in quads]))
    return SceneData(geo, MaterialTable.from_rows(rows, textures=textures), Lights.from_rows(list(lights)),
                     Sky(color=sky))


# -- scene data ------------------------------------------------------------------------------
def test_material_struct_is_96_bytes_with_texture_indices_after_the_factors():
    assert MATERIAL_DTYPE.itemsize == 96
    assert MATERIAL_DTYPE.fields["textures"][1] == 48
    assert MATERIAL_DTYPE.fields["params2"][1] == 80


def test_out_of_range_texture_indices_are_rejected_with_the_material_named():
    tex = np.ones((2, 2, 4), np.float32)
    with pytest.raises(SceneDataError, match=r"material 1 \('bad'\).*base_color_texture 1.*1 textures"):
        MaterialTable.from_rows([dict(name="ok", base_color_texture=0), dict(name="bad", base_color_texture=1)],
                                textures=[tex])
    with pytest.raises(SceneDataError, match="emission_texture -2"):
        MaterialTable.from_rows([dict(emission_texture=-2)], textures=[tex])


@pytest.mark.parametrize("bad, message", [
    (np.ones((4, 4, 4), np.uint8), "dtype uint8"),
    (np.ones((4, 4), np.float32), r"shape \(H, W, 4\)"),
    (np.ones((4, 4, 2), np.float32), r"shape \(H, W, 4\)"),
    (np.ones((0, 4, 4), np.float32), r"shape \(H, W, 4\)"),
])
def test_textures_that_are_not_float_rgba_images_are_rejected(bad, message):
    with pytest.raises(SceneDataError, match=message):
        MaterialTable.from_rows([dict(base_color_texture=0)], textures=[bad])


def test_rows_holding_image_arrays_share_one_texture_per_array_object(rng):
    checker = random_checker(rng)
    rgb = rng.uniform(0, 1, (3, 5, 3))  # float64 RGB: converted, alpha 1 added
    table = MaterialTable.from_rows([
        dict(name="a", base_color_texture=checker),
        dict(name="b", base_color_texture=checker, emission_texture=rgb),
        dict(name="c"),
    ])
    assert len(table.textures) == 2
    assert table.textures[0] is checker  # float32 RGBA arrays are used as they are, not copied
    np.testing.assert_array_equal(table.base_color_texture, [0, 0, -1])
    np.testing.assert_array_equal(table.emission_texture, [-1, 1, -1])
    assert table.textures[1].shape == (3, 5, 4) and table.textures[1].dtype == np.float32
    np.testing.assert_allclose(table.textures[1][..., :3], rgb, rtol=1e-6)
    assert (table.textures[1][..., 3] == 1).all()
    packed = table.packed()
    np.testing.assert_array_equal(packed["textures"], [[0, -1, -1, -1], [0, 1, -1, -1], [-1, -1, -1, -1]])
    assert table.has_textures and not MaterialTable.default().has_textures
    scene = SceneData(Geometry.empty(), table)
    assert scene.textures is table.textures


def test_srgb_decoding_matches_the_standard_curve():
    values = np.array([0.0, 0.04045, 0.5, 1.0], np.float32)
    np.testing.assert_allclose(srgb_to_linear(values), [0.0, 0.04045 / 12.92, 0.21404114, 1.0], rtol=1e-5)


# -- host-side packing -------------------------------------------------------------------------
def test_layer_size_is_the_largest_image_within_the_driver_limit_and_the_budget():
    assert layer_size([(64, 32, 4), (16, 128, 4)], max_size=4096, max_layers=8) == (128, 64)
    assert layer_size([(64, 8192, 4)], max_size=4096, max_layers=8) == (4096, 64)
    # 4 layers of 1024^2 RGBA16F with mipmaps take 42.7 MiB: a 16 MiB budget halves both
    # sides (10.7 MiB), an 8 MiB one halves them twice.
    assert layer_size([(1024, 1024, 4)] * 4, max_size=4096, max_layers=8, budget_bytes=16 << 20) == (512, 512)
    assert layer_size([(1024, 1024, 4)] * 4, max_size=4096, max_layers=8, budget_bytes=8 << 20) == (256, 256)
    with pytest.raises(TextureLimitError, match="9 images.*at most 8"):
        layer_size([(4, 4, 4)] * 9, max_size=4096, max_layers=8)


def test_upsampled_layers_hold_the_bilinear_samples_of_the_image(rng):
    image = random_checker(rng, (5, 7))
    up = resample(image, 16, 12)
    v, u = np.meshgrid((np.arange(12) + 0.5) / 12, (np.arange(16) + 0.5) / 16, indexing="ij")
    np.testing.assert_allclose(up, bilinear_repeat(image, np.stack([u, v], -1)), atol=1e-5)


def test_downsampled_layers_average_the_texels_they_cover(rng):
    image = random_checker(rng, (16, 16))
    down = resample(image, 4, 4)
    # A tent of radius 4 centred on each 4x4 block: a weighted mean, so it lies within the
    # block's neighbourhood range and the whole image's mean is preserved.
    np.testing.assert_allclose(down.mean(axis=(0, 1)), image.mean(axis=(0, 1)), atol=1e-5)
    np.testing.assert_allclose(resample(binary_checker(16), 4, 4)[..., :3], 0.5, atol=1e-5)


def test_packing_replaces_non_finite_negative_and_oversized_texels():
    image = np.array([[[np.nan, np.inf, -np.inf, 1.0], [-2.0, 1e6, 0.25, 1.0]]], np.float32)
    packed = pack_layers([image], 2, 1).astype(np.float32)
    np.testing.assert_array_equal(packed[0, 0], [[0.0, HALF_MAX, 0.0, 1.0], [0.0, HALF_MAX, 0.25, 1.0]])


def test_pixel_footprint_matches_the_angle_between_neighbouring_pixel_rays():
    camera = Camera(matrix_world=look_at((1, -4, 2), (0, 0, 0)), width=40, height=30, lens=35.0)
    width, spread = pixel_footprint(camera.view_projection(), camera.height, False)
    _, dirs = camera.pixel_rays()
    angle = math.acos(float(np.dot(dirs[15, 20], dirs[16, 20])))
    assert width == 0.0 and spread == pytest.approx(angle, rel=1e-3)
    ortho = Camera(matrix_world=look_at((0, 0, 5), (0, 0, 0), up=(0, 1, 0)), width=40, height=40,
                   projection="ORTHO", ortho_scale=2.0)
    width, spread = pixel_footprint(ortho.view_projection(), ortho.height, True)
    assert width == pytest.approx(2.0 / 40, rel=1e-6) and spread == 0.0


def test_triangle_uv_rows_hold_corner_uvs_and_uv_density(ctx):
    """The rows the instance transform writes on the GPU for the tracer's textured hits."""
    from hybrid_engine.passes.scene_upload.scene_buffers import GPUScene

    tris, uvs = textured_quad((0, 0, 0), (2, 0, 0), (0, 2, 0), (0.25, 0.5), (0.5, 0.5))
    scene = scene_of([(tris, uvs, 0), (tris, uvs, 1)],
                     [dict(base_color_texture=0), dict()], [np.ones((2, 2, 4), np.float32)])
    gpu = GPUScene(ctx)
    try:
        gpu.upload(scene)
        gpu.transform()
        rows = np.frombuffer(gpu.uv_rows.buffer.read(size=4 * TRIANGLE_UV_DTYPE.itemsize), TRIANGLE_UV_DTYPE)
    finally:
        gpu.release()
    flat = rows.view(np.float32).reshape(-1, 8)
    np.testing.assert_allclose(flat[:, :6], np.concatenate([uvs, uvs]).reshape(4, 6))
    np.testing.assert_allclose(flat[:, 6], 0.25, rtol=1e-6)  # sqrt(UV area 0.125 / world area 2)


# -- the GPU texture array -------------------------------------------------------------------
PROBE_SOURCE = """
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Queries { vec4 queries[]; };  // uv, layer, lod
layout(std430, binding = 1) writeonly buffer Results { vec4 results[]; };
layout(std430, binding = 2) readonly buffer MaterialBuffer { Material materials[]; };
uniform int u_count;
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= uint(u_count)) return;
    vec4 q = queries[i];
    results[i] = vec4(texture_rgb_lod(int(q.z), q.xy, q.w), 0.0);
    if (i < uint(materials.length())) {  // read-back of the struct layout
        Material m = materials[i];
        results[u_count + i] = vec4(vec2(m.textures.xy), m.params.x, m.emission_trans.a);
    }
}
"""


def probe_program(ctx):
    include = REPO_ROOT / "gpu_shaders" / "include"
    parts = ["#version 430 core"]
    for name in ("scene_layout.glsl", "textures.glsl"):
        parts += [line for line in (include / name).read_text().splitlines() if not line.startswith("#include")]
    return ctx.compute_shader("\n".join(parts) + PROBE_SOURCE)


def probe(ctx, textures: GPUTextures, queries: np.ndarray, table: MaterialTable) -> tuple[np.ndarray, np.ndarray]:
    prog = probe_program(ctx)
    queries = np.ascontiguousarray(queries, np.float32)
    count = len(queries)
    q_buf = ctx.buffer(queries.tobytes())
    out = ctx.buffer(reserve=(count + len(table)) * 16)
    m_buf = ctx.buffer(table.packed().tobytes())
    try:
        q_buf.bind_to_storage_buffer(0)
        out.bind_to_storage_buffer(1)
        m_buf.bind_to_storage_buffer(2)
        textures.array.use(location=0)
        prog["u_textures"].value = 0
        prog["u_count"].value = count
        prog.run(math.ceil(count / 64))
        raw = np.frombuffer(out.read(), np.float32).reshape(-1, 4)
    finally:
        for obj in (q_buf, out, m_buf, prog):
            obj.release()
    return raw[:count, :3], raw[count:]


def test_array_samples_equal_bilinear_lookups_with_repeat_wrapping_and_the_material_layout_reads_back(ctx, rng):
    """Level-0 samples of two layers at random UVs in [-2, 3]^2 (wrapped) against the exact
    bilinear oracle; the same kernel reads the Material structs back (texture indices and
    the fields around them), so a std430 mismatch fails here."""
    checkers = [random_checker(rng, (8, 8)), random_checker(rng, (8, 8))]
    table = MaterialTable.from_rows([dict(ior=1.3, base_color_texture=1, emission_texture=0),
                                     dict(ior=1.7, transmission=0.25, base_color_texture=0)], textures=checkers)
    gpu = GPUTextures(ctx)
    try:
        assert gpu.upload(table.textures)
        uv = rng.uniform(-2.0, 3.0, (500, 2))
        layer = np.arange(500) % 2
        queries = np.column_stack([uv, layer, np.zeros(500)])
        got, structs = probe(ctx, gpu, queries, table)
    finally:
        gpu.release()
    for k in range(2):
        expected = bilinear_repeat(checkers[k], uv[layer == k])[:, :3]
        np.testing.assert_allclose(got[layer == k], expected, atol=texel_tolerance(checkers[k]))
    np.testing.assert_allclose(structs, [[1, 0, 1.3, 0.0], [0, -1, 1.7, 0.25]], atol=1e-6)


def test_array_has_box_filtered_mipmaps(ctx):
    """Level 1 of a single-texel black/white checker is uniform grey; the last level is the mean."""
    gpu = GPUTextures(ctx)
    try:
        gpu.upload([binary_checker(16)])
        uv = np.array([[0.1, 0.2], [0.55, 0.7], [0.9, 0.35]])
        queries = np.concatenate([np.column_stack([uv, np.zeros(3), np.full(3, lod)]) for lod in (1.0, 4.0)])
        got, _ = probe(ctx, gpu, queries, MaterialTable.default())
    finally:
        gpu.release()
    np.testing.assert_allclose(got, 0.5, atol=HALF_RTOL)


def test_the_array_is_uploaded_only_when_the_images_change(ctx, rng):
    gpu = GPUTextures(ctx)
    try:
        a, b = random_checker(rng), random_checker(rng)
        assert gpu.upload([a, b]) and gpu.uploads == 1
        assert not gpu.upload([a, b])  # the same arrays: nothing to do
        assert not gpu.upload([a.copy(), b.copy()])  # equal contents in new arrays: nothing either
        assert gpu.upload([b, a]) and gpu.uploads == 2  # another order is another layer mapping
        assert gpu.upload([]) and gpu.array is not None  # no images: the 1x1 white layer
        assert gpu.uploads == 3 and not gpu.upload([])
    finally:
        gpu.release()


def test_frames_of_the_same_scene_upload_the_images_once(renderer, rng):
    """Playback: every frame builds a new SceneData around the same image arrays."""
    checker = random_checker(rng)
    tris, uvs = textured_quad((-1, -1, 0), (2, 0, 0), (0, 2, 0), (0, 0), (1, 1))
    camera = top_down_camera(size=16)
    before = renderer.gpu_scene.textures.uploads
    for _ in range(3):
        scene = scene_of([(tris, uvs, 0)], [dict(base_color_texture=0)], [checker])
        renderer.render(scene, camera, RenderSettings(mode="RASTER"), timing=False)
    assert renderer.gpu_scene.textures.uploads == before + 1


# -- the primary G-buffer -------------------------------------------------------------------
def top_down_camera(size=64, scale=2.0) -> Camera:
    return Camera(matrix_world=look_at((0, 0, 3), (0, 0, 0), up=(0, 1, 0)), width=size, height=size,
                  projection="ORTHO", ortho_scale=scale, clip_start=0.1, clip_end=10.0)


def plane_uv(camera, z, uv_of_xy):
    origins, dirs = camera.pixel_rays()
    t = (z - origins[..., 2]) / dirs[..., 2]
    points = origins + dirs * t[..., None]
    return uv_of_xy(points[..., 0], points[..., 1])


def gbuffer_of(renderer, scene, camera):
    renderer.render(scene, camera, RenderSettings(mode="RASTER"))
    targets = renderer.gbuffer.primary
    return targets.read_albedo(), targets.read_emission_scale()


def test_gbuffer_albedo_is_the_texture_at_each_pixels_uv_times_the_base_colour(renderer, rng):
    """A plane seen from above whose UVs run from -0.5 to 1.5 (two wraps) over [-1, 1]^2:
    every pixel's albedo is the bilinear texel at its analytic UV, tinted by the factor."""
    checker = random_checker(rng)
    tint = np.array([0.5, 1.0, 0.8], np.float32)
    tris, uvs = textured_quad((-1, -1, 0), (2, 0, 0), (0, 2, 0), (-0.5, -0.5), (2.0, 2.0))
    scene = scene_of([(tris, uvs, 0)], [dict(base_color=tuple(tint), base_color_texture=0)], [checker])
    camera = top_down_camera(scale=1.9)  # every pixel on the plane
    albedo, emission_scale = gbuffer_of(renderer, scene, camera)
    uv = plane_uv(camera, 0.0, lambda x, y: np.stack([(x + 1) - 0.5, (y + 1) - 0.5], -1))
    expected = bilinear_repeat(checker, uv)[..., :3] * tint
    error = np.abs(albedo[..., :3] - expected)
    if error.max() > texel_tolerance(checker):
        save_failure_images("texture_gbuffer", got=albedo, expected=expected)
    assert error.max() <= texel_tolerance(checker)
    assert (emission_scale[..., :3] == 1).all()  # no emission texture: scale 1


def test_gbuffer_samples_a_minified_checker_from_its_mipmaps(renderer):
    """A single-texel checker repeated 64 times across 64 pixels: sampling level 0 would
    alias into a pattern, the mipmaps give the mean grey everywhere."""
    tris, uvs = textured_quad((-1, -1, 0), (2, 0, 0), (0, 2, 0), (0, 0), (64.0, 64.0))
    scene = scene_of([(tris, uvs, 0)], [dict(base_color=(1, 1, 1), base_color_texture=0)], [binary_checker(16)])
    albedo, _ = gbuffer_of(renderer, scene, top_down_camera(scale=1.9))
    np.testing.assert_allclose(albedo[..., :3], 0.5, atol=0.02)


def test_emission_texture_multiplies_the_emission_in_the_shaded_image(renderer, rng):
    """RASTER: an emissive plane with an emission texture and no lights shows emission x
    texture at every pixel; the base-colour path is independent (black here)."""
    glow = random_checker(rng, (4, 4))
    strength = np.array([2.0, 1.0, 0.5], np.float32)
    tris, uvs = textured_quad((-1, -1, 0), (2, 0, 0), (0, 2, 0), (0.0, 0.0), (1.0, 1.0))
    scene = scene_of([(tris, uvs, 0)], [dict(base_color=(0, 0, 0), emission=tuple(strength), emission_texture=0)],
                     [glow])
    camera = top_down_camera(scale=1.9)
    image = renderer.render(scene, camera, RenderSettings(mode="RASTER")).image
    uv = plane_uv(camera, 0.0, lambda x, y: np.stack([(x + 1) / 2, (y + 1) / 2], -1))
    expected = bilinear_repeat(glow, uv)[..., :3] * strength
    np.testing.assert_allclose(image[..., :3], expected, atol=texel_tolerance(glow, float(strength.max())))


# -- the cube-map faces ---------------------------------------------------------------------
def test_cube_face_texels_hold_the_uv_and_uv_density_where_their_ray_meets_the_floor(gl, rng):
    """A textured floor below the near cube seen by the -Z face: every face texel stores
    the UV where its ray meets the floor and the floor's UV density (the tracer samples
    the texture there at cube-map hits)."""
    checker = random_checker(rng)
    tris, uvs = textured_quad((-4, -4, -3), (8, 0, 0), (0, 8, 0), (0.0, 0.0), (2.0, 2.0))
    scene = scene_of([(tris, uvs, 0)], [dict(base_color=(1, 1, 1), base_color_texture=0)], [checker])
    settings = RenderSettings(near_size=1.0, cube_far=20.0, cube_resolution=32)
    raster, gpu = GBufferPass(gl), GPUScene(gl)
    cube = CubeMapPass(gl, raster)
    try:
        gpu.upload(scene)
        gpu.transform()
        cube.render(gpu, scene, (0.0, 0.0, 0.0), settings)
        surface = cube.targets.read("surface")
        faces = cube.faces
    finally:
        cube.release()
        raster.release()
        gpu.release()
    res, face = 32, 5  # -Z
    got = surface[:, face * res:(face + 1) * res]
    ndc = (np.arange(res) + 0.5) / res * 2 - 1
    nx, ny = np.meshgrid(ndc, ndc)
    clip = np.stack([nx, ny, np.ones_like(nx), np.ones_like(nx)], -1) @ faces.inv_view_proj[face].T
    dirs = clip[..., :3] / clip[..., 3:]  # far-plane points seen from the centre (origin)
    points = dirs * (-3.0 / dirs[..., 2:3])
    uv = np.stack([(points[..., 0] + 4) / 8 * 2, (points[..., 1] + 4) / 8 * 2], -1)
    np.testing.assert_allclose(got[..., :2], uv, atol=1e-4)
    np.testing.assert_allclose(got[..., 2], 2.0 / 8.0, rtol=1e-3)  # sqrt(UV area / world area)


# -- BVH hits in the tracer ------------------------------------------------------------------
SUN_IRRADIANCE = 3.0
EMISSION_FACTOR = (0.2, 0.3, 0.1)


def mirror_and_wall_scene(albedo_tex, glow_tex, wall_uv_span=(2.0, 2.0)):
    """A mirror in z = 0 and, behind it, a wall y = 2 facing -Y (x in [-2, 2], z in [0, 4]),
    lit head-on by an unshadowed sun, with base-colour and emission textures."""
    mirror = textured_quad((-1, -1, 0), (2, 0, 0), (0, 2, 0), (0, 0), (1, 1))
    wall = textured_quad((-2, 2, 0), (4, 0, 0), (0, 0, 4), (0, 0), wall_uv_span)
    rows = [dict(name="mirror", base_color=(1, 1, 1), reflectivity=1.0),
            dict(name="wall", base_color=(1, 1, 1), base_color_texture=0,
                 emission=EMISSION_FACTOR, emission_texture=1)]
    sun = dict(kind="SUN", direction=(0, 1, 0), color=(SUN_IRRADIANCE,) * 3, cast_shadow=False)
    return scene_of([(*mirror, 0), (*wall, 1)], rows, [albedo_tex, glow_tex], lights=[sun])


def mirror_camera(size=48) -> Camera:
    """Orthographic, looking down at 45° along +Y onto the mirror; every pixel sees it."""
    return Camera(matrix_world=look_at((0, -2, 2), (0, 0, 0)), width=size, height=size,
                  projection="ORTHO", ortho_scale=1.2, clip_start=0.1, clip_end=20.0)


def reflected_wall_uv(camera, wall_uv_span=(2.0, 2.0)):
    origins, dirs = camera.pixel_rays()
    t = -origins[..., 2] / dirs[..., 2]
    on_mirror = origins + dirs * t[..., None]
    assert (np.abs(on_mirror[..., :2]) < 1).all()
    reflected = dirs * np.array([1, 1, -1])
    s = (2.0 - on_mirror[..., 1]) / reflected[..., 1]
    wall = on_mirror + reflected * s[..., None]
    return np.stack([(wall[..., 0] + 2) / 4 * wall_uv_span[0], wall[..., 2] / 4 * wall_uv_span[1]], -1)


@pytest.mark.parametrize("mode", ["HYBRID", "FULL_BVH"])
def test_a_mirror_shows_the_wall_textures_sampled_at_bvh_hits(renderer, rng, mode):
    """The wall is seen only in the mirror, so its colour comes from BVH hits (in HYBRID the
    near cube holds the whole scene): albedo texture lit by the sun plus emission texture,
    both at the UV where the reflected ray meets the wall."""
    albedo_tex, glow_tex = random_checker(rng), random_checker(rng)  # one size: no resampling
    scene = mirror_and_wall_scene(albedo_tex, glow_tex)
    camera = mirror_camera()
    settings = RenderSettings(mode=mode, near_size=8.0, cube_resolution=32, cube_far=50.0, max_depth=2)
    image = renderer.render(scene, camera, settings).image
    uv = reflected_wall_uv(camera)
    expected = (bilinear_repeat(albedo_tex, uv)[..., :3] / np.pi * SUN_IRRADIANCE
                + bilinear_repeat(glow_tex, uv)[..., :3] * np.array(EMISSION_FACTOR))
    tolerance = texel_tolerance(albedo_tex, SUN_IRRADIANCE / np.pi) + texel_tolerance(glow_tex, max(EMISSION_FACTOR))
    error = np.abs(image[..., :3] - expected)
    if error.max() > tolerance:
        save_failure_images(f"texture_bvh_{mode}", got=image, expected=expected)
    assert error.max() <= tolerance


# Where a cube-map hit takes the texture: at the UV of the face texel the march ends in,
# within a texel or so of the true hit. At 512 texels per face and 4-5 m from the map's
# centre a texel is 2 cm of wall, 0.01 in UV, 0.08 of the checker's texels: a bilinear
# sample moves by at most that fraction of the checker's contrast.
CUBE_HIT_TEXEL_SHIFT = 0.25  # of a checker texel, with a margin for the march's refinement


def test_a_mirror_shows_the_wall_textures_sampled_at_cube_map_hits(renderer, rng):
    """As above, but with a near cube too small to hold the wall: every reflected ray finds
    the wall in the cube map, whose faces keep the UV, and is textured there (albedo and
    emission), as a BVH hit would be."""
    albedo_tex, glow_tex = random_checker(rng), random_checker(rng)
    scene = mirror_and_wall_scene(albedo_tex, glow_tex)
    camera = mirror_camera()
    settings = RenderSettings(mode="HYBRID", near_size=0.5, cube_resolution=512, cube_far=50.0, max_depth=1)
    result = renderer.render(scene, camera, settings)
    assert result.counts["triangles_bvh"] == 0
    assert result.counts["rays_cube_map_bounce_1"] == result.counts["rays_traced_bounce_1"] > 0
    uv = reflected_wall_uv(camera)
    expected = (bilinear_repeat(albedo_tex, uv)[..., :3] / np.pi * SUN_IRRADIANCE
                + bilinear_repeat(glow_tex, uv)[..., :3] * np.array(EMISSION_FACTOR))
    contrast = (np.ptp(albedo_tex[..., :3]) / np.pi * SUN_IRRADIANCE
                + np.ptp(glow_tex[..., :3]) * max(EMISSION_FACTOR))
    tolerance = CUBE_HIT_TEXEL_SHIFT * contrast
    error = np.abs(result.image[..., :3] - expected)
    if error.max() > tolerance:
        save_failure_images("texture_cube_hit", got=result.image, expected=expected)
    assert error.max() <= tolerance
    assert np.median(error) <= 0.1 * tolerance


def test_bvh_hits_on_a_minified_checker_sample_a_coarser_mip_level(renderer):
    """The wall's single-texel checker repeated so that one pixel's footprint covers about
    five texels: the ray cone picks a level >= 1, which is uniform grey (level 0 would
    alias into black and white)."""
    span = (32.0, 32.0)
    scene = mirror_and_wall_scene(binary_checker(32), np.zeros((1, 1, 4), np.float32), span)
    image = renderer.render(scene, mirror_camera(), RenderSettings(mode="FULL_BVH", max_depth=1)).image
    np.testing.assert_allclose(image[..., :3], 0.5 / np.pi * SUN_IRRADIANCE, rtol=0.03)


@pytest.mark.parametrize("roughness, grey_share", [(0.0, (0.0, 0.6)), (0.4, (0.9, 1.0))])
def test_one_sample_of_a_rough_reflection_shows_the_texture_as_blurred_as_its_lobe(renderer, roughness, grey_share):
    """The wall's single-texel checker, reflected by a mirror (level 0 seen: bilinear ramps
    between black and white texels, grey on 40 % of the wall) and by a metal of roughness 0.4
    in one sample: its ray cone widens with the lobe, so the wall is sampled at a level >= 1,
    uniform grey, instead of level 0 along the lobe's random directions (43 % grey)."""
    span = (2.0, 2.0)  # a texel of the wall covers several pixels
    scene = mirror_and_wall_scene(binary_checker(32), np.zeros((1, 1, 4), np.float32), span)
    rows = [dict(name="mirror", base_color=(1, 1, 1), reflectivity=1.0, roughness=roughness),
            dict(name="wall", base_color=(1, 1, 1), base_color_texture=0, emission_texture=1)]
    scene = SceneData(scene.geometry, MaterialTable.from_rows(rows, textures=scene.materials.textures), scene.lights,
                      scene.sky)
    image = renderer.render(scene, mirror_camera(), RenderSettings(mode="FULL_BVH", max_depth=1), sample=0).image
    value = image[..., 1].ravel()
    wall = value[value > 1e-3]  # pixels whose ray met the wall (the others see the black sky)
    grey = 0.5 / np.pi * SUN_IRRADIANCE
    share = float(np.mean(np.abs(wall - grey) < 0.15 * grey))
    assert wall.size > 0.5 * value.size
    assert grey_share[0] <= share <= grey_share[1], share


# -- normal maps -----------------------------------------------------------------------------
def tilted_normal_map(angle: float, size: int = 8) -> np.ndarray:
    """A normal map whose every texel leans the normal by ``angle`` towards the UVs' +u."""
    n = np.array([np.sin(angle), 0.0, np.cos(angle)])
    return np.broadcast_to(np.append(n * 0.5 + 0.5, 1.0), (size, size, 4)).astype(np.float32).copy()


@pytest.mark.parametrize("strength", [1.0, 0.5])
def test_a_normal_map_tilts_the_lit_normal_of_primary_pixels_and_of_reflections(renderer, strength):
    """A floor whose normal map leans its normal 40 degrees towards +x, under a sun straight
    above: Lambert's cosine of the blended normal, seen directly (the G-buffer path) and in a
    mirror (the tracer's BVH hits) alike."""
    angle = np.radians(40.0)
    floor = textured_quad((-4, -4, 0), (8, 0, 0), (0, 8, 0), (0, 0), (4, 4))  # u along +x
    mirror = textured_quad((-4, 3, 0), (8, 0, 0), (0, -1.5, 4), (0, 0), (1, 1))  # leans over the floor
    rows = [dict(base_color=(0.8, 0.8, 0.8), normal_texture=0, normal_strength=strength),
            dict(base_color=(1, 1, 1), reflectivity=1.0)]
    sun = dict(kind="SUN", direction=(0, 0, -1), color=(3.0, 3.0, 3.0), cast_shadow=False)
    scene = scene_of([(*floor, 0), (*mirror, 1)], rows, [tilted_normal_map(angle)], lights=[sun])
    mapped = np.array([np.sin(angle), 0.0, np.cos(angle)])
    blended = (1 - strength) * np.array([0.0, 0.0, 1.0]) + strength * mapped
    expected = 0.8 / np.pi * 3.0 * (blended / np.linalg.norm(blended))[2]
    camera = Camera(matrix_world=look_at((0, -6, 2.5), (0, 1, 0.5)), width=64, height=48)
    image = renderer.render(scene, camera, RenderSettings(mode="FULL_BVH", ao_distance=0.0, world_light="SCREEN"),
                            timing=False).image
    origins, dirs = camera.pixel_rays()
    t = ray_plane_z(origins, dirs)
    hit = origins + dirs * np.where(np.isfinite(t), t, 0)[..., None]
    direct = np.isfinite(t) & (np.abs(hit[..., 0]) < 3.5) & (hit[..., 1] > -3.5) & (hit[..., 1] < 1.0)
    np.testing.assert_allclose(image[direct][:, 1].mean(), expected, rtol=0.02)
    # Pixels that see the floor in the mirror: the same tilted shading, found by the tracer.
    corner, eu, ev = np.array([-4.0, 3.0, 0.0]), np.array([8.0, 0.0, 0.0]), np.array([0.0, -1.5, 4.0])
    normal = np.cross(eu, ev) / np.linalg.norm(np.cross(eu, ev))
    with np.errstate(divide="ignore", invalid="ignore"):
        tm = ((corner - origins) @ normal) / (dirs @ normal)
    at = origins + dirs * tm[..., None]
    s_, t_ = (at - corner) @ eu / (eu @ eu), (at - corner) @ ev / (ev @ ev)
    bounced = dirs - 2.0 * (dirs @ normal)[..., None] * normal
    tf = -at[..., 2] / bounced[..., 2]
    floor_hit = at + bounced * tf[..., None]
    in_mirror = ((tm > 0) & (s_ > 0.1) & (s_ < 0.9) & (t_ > 0.05) & (t_ < 0.95) & (tf > 0)
                 & (np.abs(floor_hit[..., 0]) < 3.5) & (floor_hit[..., 1] > -3.5) & (floor_hit[..., 1] < 1.0))
    assert in_mirror.sum() > 50
    np.testing.assert_allclose(image[in_mirror][:, 1].mean(), expected, rtol=0.03)
    assert abs(expected / (0.8 / np.pi * 3.0) - 1.0) > 0.05  # the map really changes the shading
