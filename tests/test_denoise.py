# SPDX-License-Identifier: GPL-3.0-or-later
"""The denoiser of the frame's ambient estimate (hybrid_engine/passes/denoise/,
gpu_shaders/denoise/): its history follows surfaces through the camera's motion and is
dropped where a moved object uncovers what lay behind it; its filter removes the noise of
the irradiance but keeps a texture's edges (the albedo multiplies after) and never touches
a mirror (the tracer's reflections are not in the estimate).

Most tests feed the denoiser a known estimate: a probe kernel (tests/shaders/
ambient_probe.comp.glsl) stands in for the ambient occlusion and writes an irradiance that
belongs to each surface point, with or without deterministic noise of mean 1, so the
noise-free image is known exactly. The last tests run the real estimate (rays through the
BVH) end to end.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from hybrid_engine import Camera, Geometry, Lights, MaterialTable, RenderSettings, SceneData, Sky
from hybrid_engine.frame.accumulation import sample_offset
from hybrid_engine.frame.antialias import jittered_camera, render_antialiased
from hybrid_engine.frame.film import FrameOutputs
from hybrid_engine.frame.renderer import READBACK_READS, Renderer, frame_steps
from hybrid_engine.gpu import shader_loader
from hybrid_engine.gpu.bindings import Image, bind
from hybrid_engine.passes.frame_context import FrameContext, PassIO, check_order
from hybrid_engine.scene.camera import look_at
from scenes_analytic import box, quad

PROBE = Path(__file__).resolve().parent / "shaders" / "ambient_probe.comp.glsl"
RASTER = RenderSettings(mode="RASTER", shadow_resolution=256)


class ProbeAmbient:
    """The frame's ambient estimate, replaced by the probe kernel's known irradiance:
    ``pattern`` 0 a smooth function of the world position, 1 the constant ``level``, 3 a
    linear ramp across x (tests/shaders/ambient_probe.comp.glsl); each
    pixel times 1 + ``noise`` * xi, xi uniform in [-1, 1] per pixel and sample."""

    name = "shade"

    def __init__(self, ctx, pattern: int = 0, level: float = 0.6, noise: float = 0.0) -> None:
        self.program = shader_loader.compute(ctx, PROBE)
        self.pattern, self.level, self.noise = pattern, level, noise

    def io(self, settings) -> PassIO:
        return PassIO(reads=("gbuffer",), writes=("ambient",))

    def run(self, frame: FrameContext) -> None:
        targets = frame.read("gbuffer")
        view = frame.view
        bind(self.program, textures={"u_depth": targets.depth, "u_normal_material": targets.normal_material},
             images={"u_ambient": Image(targets.ambient, read=False, write=True)},
             uniforms={"u_inv_view_proj": view.uniforms()["u_inv_view_proj"], "u_size": (view.width, view.height),
                       "u_pattern": self.pattern, "u_level": self.level, "u_noise": self.noise,
                       "u_sample": frame.sample})
        self.program.run(math.ceil(view.width / 8), math.ceil(view.height / 8), 1)
        frame.write("ambient", targets.ambient)


@pytest.fixture(scope="module")
def renderer(gl):
    r = Renderer(gl)
    yield r
    r.release()


@pytest.fixture
def probe(renderer, monkeypatch):
    """Install a probe estimate in place of the screen-space occlusion: ``probe(**kw)``."""
    def install(**kw) -> ProbeAmbient:
        stand_in = ProbeAmbient(renderer.ctx, **kw)
        monkeypatch.setattr(renderer, "occlusion", stand_in)
        return stand_in
    yield install
    if renderer.denoiser is not None:
        renderer.denoiser.forget()


def grey(rows=None, textures=None) -> MaterialTable:
    return MaterialTable.from_rows(rows or [dict(base_color=(0.8, 0.8, 0.8))], textures=textures)


def history_length(renderer) -> np.ndarray:
    """Each pixel's history length after the last frame, (H, W), row 0 at the bottom."""
    return renderer.denoiser.history.read("length")[..., 0]


# -- the frame -------------------------------------------------------------------------------
@pytest.mark.parametrize("settings", [RASTER, RenderSettings(mode="HYBRID", world_light="SCREEN"), RenderSettings(mode="HYBRID")],
                         ids=["raster", "hybrid", "rays"])
def test_a_denoised_frame_filters_the_estimate_between_its_pass_and_the_shading(renderer, settings):
    passes = renderer.passes(settings, accumulate=True, denoise=True)
    check_order(passes, settings, final_reads=READBACK_READS + ("film",))
    names = [type(p).__name__ for p in passes]
    at = names.index("DenoisePass")
    assert names[at - 1] in ("ScreenSpaceOcclusion", "DiffuseLightPass") and names[at + 1] == "DeferredShadePass"
    # The instances' moves, which its reprojection and the diffuse gather follow: right after
    # the primary G-buffer, in its step.
    assert names[names.index("GBufferPass") + 1] == "SurfaceMotionPass"
    assert list(dict.fromkeys(p.name for p in passes)) + ["readback"] == list(
        frame_steps(settings.mode, accumulate=True, denoise=True))
    assert "DenoisePass" not in [type(p).__name__ for p in renderer.passes(settings, accumulate=True)]


# -- temporal: reprojection through the camera's motion ------------------------------------------
def test_the_history_follows_the_surface_while_the_camera_translates(renderer, probe):
    """A floor whose irradiance is a smooth function of the world position, with noise:
    while the camera slides sideways (a few pixels per frame) every pixel it keeps seeing
    gathers one frame more each frame, and what it gathers is its own point's irradiance
    (the error against the noise-free image falls instead of smearing the pattern)."""
    floor = SceneData(Geometry.from_objects([(quad((0, 0, 0), (20, 0, 0), (0, 20, 0)), None, 0)]), grey(),
                      Lights.empty(), Sky(color=(1.0, 1.0, 1.0)))
    w, h, frames, step = 96, 64, 10, 0.1

    def camera(k: int) -> Camera:
        eye = np.array([k * step, -5.0, 4.0])
        return Camera(matrix_world=look_at(eye, eye + (0.0, 5.0, -4.0)), width=w, height=h)

    probe(pattern=0, noise=0.0)
    clean = [renderer.render(floor, camera(k), RASTER).image[..., :3] for k in range(frames)]
    probe(pattern=0, noise=0.6)
    errors = []
    for k in range(frames):
        image = renderer.render(floor, camera(k), RASTER, sample=k, denoise=True).image[..., :3]
        errors.append(float(np.abs(image - clean[k])[:, : w * 3 // 4].mean() / clean[k].mean()))
    assert errors[-1] < 0.7 * errors[0], errors
    lengths = history_length(renderer)
    # The camera moves right: what enters on the right is new; the rest was seen all along.
    kept = lengths[:, : w * 3 // 4]
    assert (kept >= frames).mean() > 0.95, np.percentile(kept, [1, 5, 50])
    assert (lengths[:, -2:] <= 2).all()  # the entering edge starts over


def test_a_sub_pixel_camera_translation_keeps_the_contrast_of_a_sharp_pattern_in_the_history(renderer, probe):
    """Stripes with edges sharper than a pixel, on a floor the camera slides over by a
    fraction of a pixel per frame, without noise: the history reprojected over a dozen
    frames keeps most of the stripes' contrast (the fetch is a clamped Catmull-Rom cubic),
    where a bilinear fetch blurs it a little more at every frame's shift."""
    floor = SceneData(Geometry.from_objects([(quad((-20, -20, 0), (40, 0, 0), (0, 40, 0)), None, 0)]), grey(),
                      Lights.empty(), Sky(color=(1.0, 1.0, 1.0)))
    w, h, frames, step = 64, 48, 12, 0.03

    def camera(k: int) -> Camera:
        eye = np.array([k * step, -5.0, 4.0])
        return Camera(matrix_world=look_at(eye, eye + (0.0, 5.0, -4.0)), width=w, height=h)

    probe(pattern=2, level=0.3)
    if renderer.denoiser is not None:
        renderer.denoiser.forget()
    renderer.render(floor, camera(frames), RASTER, denoise=True)
    sharp = renderer.denoiser.history.read("color")[..., 0]  # a first frame: the pattern itself
    renderer.denoiser.forget()
    for k in range(frames + 1):
        renderer.render(floor, camera(k), RASTER, sample=k, denoise=True)
    carried = renderer.denoiser.history.read("color")[..., 0]
    assert (history_length(renderer)[4:-4, 4:-8] > frames).all()  # all reprojected, none started over
    inner = (slice(4, h - 4), slice(4, w - 8))
    contrast = carried[inner].std() / sharp[inner].std()
    assert contrast > 0.72, contrast


@pytest.mark.parametrize("kind", ["object moves", "lamp changes", "World changes", "camera moves", "still", "jittered"])
def test_the_history_follows_a_change_of_light_faster_while_an_object_moves_or_a_lamp_changes(renderer, probe, kind):
    """A floor's irradiance steps from 0.2 to 0.8 after a long history: while an object
    moves, and for CHANGE_FRAMES after a lamp or the World changed, the blend takes at least
    ALPHA_COLOR_CHANGING of each frame and has come most of the way after four frames (the
    room's light shifts with them, and a long history lags behind it), though the camera
    stands still; a camera that moves over a still scene keeps the lower floor and its
    smoother mean, as a still one does, also where its film's samples are jittered by
    sub-pixels (the viewport's redraws of a still view)."""
    floor = SceneData(Geometry.from_objects([(quad((-20, -20, 0), (40, 0, 0), (0, 40, 0)), None, 0)]), grey(),
                      Lights.empty(), Sky(color=(1.0, 1.0, 1.0)))
    w, h, step = 48, 32, 0.05 if kind == "camera moves" else 0.0

    def scene(k: int) -> SceneData:
        if kind == "lamp changes":  # a point lamp turned up once, as the light steps (the probe ignores it)
            lamp = dict(kind="POINT", position=(0.0, 0.0, 3.0), color=(10.0 if k < 24 else 20.0,) * 3, radius=0.1)
            return SceneData(floor.geometry, floor.materials, Lights.from_rows([lamp]), floor.sky)
        if kind == "World changes":  # the World turned up once, likewise
            world = Sky(color=(1.0, 1.0, 1.0), strength=1.0 if k < 24 else 2.0)
            return SceneData(floor.geometry, floor.materials, floor.lights, world)
        if kind != "object moves":
            return floor
        # The floor and a box behind the camera, an instance sliding by 5 cm a frame.
        return moving_box_scene((k * 0.05, -12.0, 0.0), 0.0)

    def camera(k: int) -> Camera:
        eye = np.array([k * step, -5.0, 4.0])
        still = Camera(matrix_world=look_at(eye, eye + (0.0, 5.0, -4.0)), width=w, height=h)
        return jittered_camera(still, *sample_offset(k)) if kind == "jittered" else still

    stand_in = probe(pattern=1, level=0.2)
    if renderer.denoiser is not None:
        renderer.denoiser.forget()
    accumulate = kind == "jittered"  # one film's mean: its samples follow one another
    for k in range(24):
        renderer.render(scene(k), camera(k), RASTER, sample=k, denoise=True, accumulate=accumulate,
                        reuse_world=accumulate and k > 0)
    stand_in.level = 0.8
    for k in range(24, 28):
        renderer.render(scene(k), camera(k), RASTER, sample=k, denoise=True, accumulate=accumulate,
                        reuse_world=accumulate)
    blend = float(renderer.denoiser.history.read("color")[4:-4, 4:-8, 0].mean())
    come = (blend - 0.2) / 0.6  # the share of the step the history has followed
    assert (come > 0.6) if kind in ("object moves", "lamp changes", "World changes") else (0.15 < come < 0.35), come


def test_an_object_that_moved_drops_the_history_where_it_uncovers_the_floor(renderer, probe):
    """Looking straight down at a box standing on a floor, both one material with their top
    faces parallel: only the depth tells them apart. The box slides; the floor it uncovers
    starts over (history 1), the floor it never covered keeps its frames."""
    def scene(x: float) -> SceneData:
        objects = [(quad((0, 0, 0), (20, 0, 0), (0, 20, 0)), None, 0), (box((x - 0.6, -0.6, 0), (x + 0.6, 0.6, 0.8)), None, 0)]
        return SceneData(Geometry.from_objects(objects), grey(), Lights.empty(), Sky(color=(1.0, 1.0, 1.0)))

    camera = Camera(matrix_world=look_at((0, 0, 6.0), (0, 0, 0), up=(0, 1, 0)), width=64, height=64)
    probe(pattern=1, noise=0.3)
    depth = FrameOutputs(depth=True)
    still = scene(-0.5)
    for k in range(4):
        before = renderer.render(still, camera, RASTER, sample=k, outputs=depth, denoise=True)
    after = renderer.render(scene(0.5), camera, RASTER, sample=4, outputs=depth, denoise=True)
    lengths = history_length(renderer)
    floor_depth = float(np.max(after.data_passes["depth"]))
    on_floor = lambda d: d > floor_depth - 0.1  # noqa: E731
    uncovered = ~on_floor(before.data_passes["depth"]) & on_floor(after.data_passes["depth"])
    never_covered = on_floor(before.data_passes["depth"]) & on_floor(after.data_passes["depth"])
    assert uncovered.sum() > 50
    assert (lengths[uncovered] == 1).all(), np.unique(lengths[uncovered])
    assert (lengths[never_covered] == 5).mean() > 0.98


def moving_box_scene(offset, degrees: float) -> SceneData:
    """A floor (material 0) and a box (material 1, both grey) as instances of their meshes,
    the box placed at ``offset`` turned by ``degrees`` about the vertical."""
    from hybrid_engine.scene.geometry import InstancedGeometry
    from hybrid_engine.scene.meshes import Instances
    from scenes_instanced import flat_mesh, placed, rotation_z

    floor = flat_mesh(quad((0, 0, 0), (20, 0, 0), (0, 20, 0)))
    block = flat_mesh(box((-0.6, -0.6, 0), (0.6, 0.6, 0.8)))
    instances = Instances(meshes=[floor, block], mesh=np.array([0, 1]),
                          matrices=np.array([np.eye(4), placed(rotation_z(degrees), offset)], np.float32),
                          slot_materials=[np.int32([0]), np.int32([1])])
    return SceneData(InstancedGeometry(instances), grey([dict(base_color=(0.8, 0.8, 0.8))] * 2), Lights.empty(),
                     Sky(color=(1.0, 1.0, 1.0)))


@pytest.mark.parametrize("vertices", ["cpu", "gpu"])
def test_a_moving_object_keeps_its_history_and_what_it_uncovers_starts_over(renderer, probe, monkeypatch, vertices):
    """A box slides past its own width and turns by 40 degrees under a still camera: the
    pixels of its faces the camera saw before (the top, and the side that turned by more
    than the normal test's 25 degrees) find last frame's point through its move and keep
    their frames; the side it turned into view, and the floor it uncovers, start over. Both
    shapes of the primary raster (world rows, instanced draws) give the depth the move is
    matched at."""
    monkeypatch.setenv("HYBRID_RT_KERNELS", f"vertices={vertices}")
    camera = Camera(matrix_world=look_at((3.0, -6.0, 5.0), (0, 0, 0)), width=64, height=64)
    probe(pattern=1, noise=0.3)
    for k in range(4):
        renderer.render(moving_box_scene((-0.9, 0, 0), 0.0), camera, RASTER, sample=k, denoise=True)
    ids_before = renderer.denoiser.history.read("length")[..., 1]
    after = renderer.render(moving_box_scene((0.9, 0.3, 0), 40.0), camera, RASTER, sample=4, denoise=True,
                            outputs=FrameOutputs(normal=True))
    lengths, ids = renderer.denoiser.history.read("length")[..., 0], renderer.denoiser.history.read("length")[..., 1]
    normal = after.data_passes["normal"]
    on_box, was_box = ids == 2, ids_before == 2
    assert not (on_box & was_box).any()  # the box moved clear of where it stood
    turn = np.radians(40.0)
    faces = {"top": (0.0, 0.0, 1.0), "front": (np.sin(turn), -np.cos(turn), 0.0),  # the -y side, turned
             "into view": (-np.cos(turn), -np.sin(turn), 0.0)}  # the -x side, hidden before
    seen = {name: on_box & (normal @ np.array(n) > 0.99) for name, n in faces.items()}
    assert all(mask.sum() > 20 for mask in seen.values()), {k: int(v.sum()) for k, v in seen.items()}
    for name in ("top", "front"):
        assert (lengths[seen[name]] == 5).mean() > 0.95, (name, np.unique(lengths[seen[name]], return_counts=True))
    assert (lengths[seen["into view"]] == 1).all()
    uncovered = was_box & (ids == 1)
    assert uncovered.sum() > 100 and (lengths[uncovered] == 1).all(), np.unique(lengths[uncovered])


def deforming_box_scene(floor, block, offset, degrees: float, version: int) -> SceneData:
    """moving_box_scene's box moved by deforming its mesh ``block`` (its vertices placed at
    ``offset`` turned by ``degrees``, version ``version``) under the identity matrix, as an
    armature or shape keys move a mesh; the meshes are the same from frame to frame."""
    from hybrid_engine.scene.geometry import InstancedGeometry
    from hybrid_engine.scene.meshes import Instances
    from scenes_instanced import deformed, placed, rotation_z

    instances = Instances(meshes=[floor, deformed(block, placed(rotation_z(degrees), offset), version)],
                          mesh=np.array([0, 1]), matrices=np.array([np.eye(4)] * 2, np.float32),
                          slot_materials=[np.int32([0]), np.int32([1])])
    return SceneData(InstancedGeometry(instances), grey([dict(base_color=(0.8, 0.8, 0.8))] * 2), Lights.empty(),
                     Sky(color=(1.0, 1.0, 1.0)))


@pytest.mark.parametrize("follow", [True, False])
def test_a_deforming_object_keeps_its_history_where_its_surface_moved(renderer, probe, monkeypatch, follow):
    """The moving box of the test above, moved by deforming its mesh under a still matrix (an
    armature, shape keys): the instance transform keeps last frame's rows of the deformed
    mesh, so its top and the side that turned keep their frames as a rigid move's do, and
    what turned into view or was uncovered starts over. Without those rows (``follow``
    False) every pixel of the box starts over."""
    from hybrid_engine.passes.scene_upload.previous_rows import PreviousRows
    from scenes_analytic import box as box_triangles
    from scenes_instanced import flat_mesh

    if not follow:
        monkeypatch.setattr(PreviousRows, "capture", lambda self, *args: self.clear())
    floor, block = flat_mesh(quad((0, 0, 0), (20, 0, 0), (0, 20, 0))), flat_mesh(box_triangles((-0.6, -0.6, 0), (0.6, 0.6, 0.8)))
    camera = Camera(matrix_world=look_at((3.0, -6.0, 5.0), (0, 0, 0)), width=64, height=64)
    probe(pattern=1, noise=0.3)
    for k in range(4):
        renderer.render(deforming_box_scene(floor, block, (-0.9, 0, 0), 0.0, 1), camera, RASTER, sample=k, denoise=True)
    ids_before = renderer.denoiser.history.read("length")[..., 1]
    after = renderer.render(deforming_box_scene(floor, block, (0.9, 0.3, 0), 40.0, 2), camera, RASTER, sample=4,
                            denoise=True, outputs=FrameOutputs(normal=True))
    lengths, ids = renderer.denoiser.history.read("length")[..., 0], renderer.denoiser.history.read("length")[..., 1]
    normal = after.data_passes["normal"]
    on_box, was_box = ids == 2, ids_before == 2
    assert not (on_box & was_box).any()
    turn = np.radians(40.0)
    faces = {"top": (0.0, 0.0, 1.0), "front": (np.sin(turn), -np.cos(turn), 0.0),
             "into view": (-np.cos(turn), -np.sin(turn), 0.0)}
    seen = {name: on_box & (normal @ np.array(n) > 0.99) for name, n in faces.items()}
    assert all(mask.sum() > 20 for mask in seen.values()), {k: int(v.sum()) for k, v in seen.items()}
    for name in ("top", "front"):
        kept = (lengths[seen[name]] == 5).mean()
        assert kept > 0.95 if follow else kept == 0.0, (name, np.unique(lengths[seen[name]], return_counts=True))
    assert (lengths[seen["into view"]] == 1).all()
    uncovered = was_box & (ids == 1)
    assert uncovered.sum() > 100 and (lengths[uncovered] == 1).all(), np.unique(lengths[uncovered])


# -- spatial: the filter ---------------------------------------------------------------------
def checker(cells: int, texels: int) -> np.ndarray:
    """``cells`` x ``cells`` squares of ``texels`` texels each, albedo 0.9 and 0.2."""
    i, j = np.indices((cells * texels, cells * texels)) // texels
    tex = np.ones((cells * texels, cells * texels, 4), np.float32)
    tex[..., :3] = np.where((i + j) % 2 == 1, 0.9, 0.2)[..., None]
    return tex


def test_the_filter_removes_the_irradiances_noise_and_keeps_a_textures_edges(renderer, probe):
    """A checker-textured floor seen from above, under a constant irradiance with noise: one
    denoised frame has a small fraction of the noisy frame's variance, and the checker's
    edges keep the contrast of the noise-free image, because what is filtered is the
    irradiance, before the albedo multiplies it."""
    size, cells = 96, 6
    tris = quad((0, 0, 0), (3, 0, 0), (0, 3, 0))
    uvs = ((tris[..., :2] + 3.0) / 6.0).astype(np.float32)  # the quad spans uv 0..1
    geo = Geometry.from_objects([(tris, None, 0)])
    geo = Geometry(geo.triangles, geo.normals, geo.material_ids, geo.object_ranges, geo.object_bounds,
                   geo.object_names, uvs=uvs)
    scene = SceneData(geo, grey([dict(base_color=(1.0, 1.0, 1.0), base_color_texture=0)], [checker(cells, size // cells)]),
                      Lights.empty(), Sky(color=(1.0, 1.0, 1.0)))
    camera = Camera(matrix_world=look_at((0, 0, 5.0), (0, 0, 0), up=(0, 1, 0)), width=size, height=size,
                    projection="ORTHO", ortho_scale=6.0)
    probe(pattern=1, noise=0.0)
    clean = renderer.render(scene, camera, RASTER).image[..., 0]
    probe(pattern=1, noise=0.8)
    noisy = renderer.render(scene, camera, RASTER, sample=3).image[..., 0]
    denoised = renderer.render(scene, camera, RASTER, sample=3, denoise=True).image[..., 0]

    cell = size // cells  # 16 pixels (and texels) per checker square
    inner = np.zeros((size, size), bool)
    for a in range(cells):
        for b in range(cells):
            inner[a * cell + 3:(a + 1) * cell - 3, b * cell + 3:(b + 1) * cell - 3] = True
    # The contrast across every vertical edge between squares: the pixels on its two sides.
    left = np.arange(cell - 1, size - 1, cell)
    contrast = lambda image: np.abs(image[:, left] - image[:, left + 1]).mean()  # noqa: E731
    assert contrast(denoised) == pytest.approx(contrast(clean), rel=0.03), (contrast(denoised), contrast(clean))
    residual = lambda image: np.var((image / clean)[inner])  # noqa: E731
    assert residual(denoised) < residual(noisy) / 20, (residual(denoised), residual(noisy))


def step_floor(renderer, probe):
    """A floor whose light rises steadily across it (the probe's ramp), up to a step to a
    raised floor, seen from above; returns the scene, the camera, the clean image and the
    pixels of the floor beside the step (8 columns)."""
    floor = quad((-0.75, 0, 0), (2.25, 0, 0), (0, 3, 0))  # x from -3 to 1.5
    step = quad((2.25, 0, 0.5), (0.75, 0, 0), (0, 3, 0))  # a raised floor beyond x = 1.5
    scene = SceneData(Geometry.from_objects([(floor, None, 0), (step, None, 0)]), grey(), Lights.empty(),
                      Sky(color=(1.0, 1.0, 1.0)))
    size = 96
    camera = Camera(matrix_world=look_at((0, 0, 5.0), (0, 0, 0), up=(0, 1, 0)), width=size, height=size,
                    projection="ORTHO", ortho_scale=4.0)
    probe(pattern=3, level=0.5, noise=0.0)
    clean = renderer.render(scene, camera, RASTER).image[..., 0]
    xs = (np.arange(size) + 0.5) / size * 4.0 - 2.0
    beside = (slice(size // 4, 3 * size // 4), (xs > 1.1) & (xs < 1.45))
    return scene, camera, clean, beside


def bias_beside_the_step(renderer, scene, camera, clean, beside, frames: int = 8) -> float:
    """The mean relative error of the pixels ``beside`` the step after ``frames`` denoised
    frames of a history that starts over (their noise averages out over the 8 x 48 pixels)."""
    renderer.render(scene, camera, RASTER)  # undenoised: the history starts over
    for k in range(frames):  # a history past MIN_LENGTH: the planes are fitted
        image = renderer.render(scene, camera, RASTER, sample=k, denoise=True).image[..., 0]
    return float((image - clean)[beside[0]][:, beside[1]].mean() / clean[beside[0]][:, beside[1]].mean())


def test_the_coarsest_level_keeps_a_gradient_of_light_where_an_edge_cuts_its_kernel_off(renderer, probe, monkeypatch):
    """Light that rises steadily across a floor, up to a step to a raised floor: beside the
    step the plane stop cuts the kernel off on one side, and the mean of the taps left is the
    (dimmer) light of a place farther from it, which the pixels beside the step take: a dark
    band as wide as the kernel. The coarsest level's plane through its taps, taken at the
    pixel itself, keeps the ramp there."""
    scene, camera, clean, beside = step_floor(renderer, probe)
    probe(pattern=3, level=0.5, noise=0.4)
    monkeypatch.setattr("hybrid_engine.passes.denoise.denoise.LINEAR_LEVELS", 1)

    def bias(linear: bool) -> float:
        monkeypatch.setattr("hybrid_engine.passes.denoise.denoise.LINEAR_FIT", linear)
        return bias_beside_the_step(renderer, scene, camera, clean, beside)

    with_plane, with_mean = bias(True), bias(False)
    assert with_mean < -0.0015, with_mean  # darker: the taps left lie down the ramp
    assert abs(with_plane) < abs(with_mean) / 4, (with_plane, with_mean)


def test_planes_at_the_coarser_levels_keep_the_ramp_beside_an_edge_closer_than_one_at_the_coarsest(
        renderer, probe, monkeypatch):
    """The finer levels' means are cut off at the step too, each a little down the ramp, and
    a plane at the coarsest level alone fits what they left: a plane at each of the default
    ``LINEAR_LEVELS`` takes that level's value at the pixel itself."""
    from hybrid_engine.passes.denoise import denoise

    assert denoise.LINEAR_LEVELS > 1
    scene, camera, clean, beside = step_floor(renderer, probe)
    probe(pattern=3, level=0.5, noise=0.4)
    found = {}
    for levels in (1, denoise.LINEAR_LEVELS):
        monkeypatch.setattr("hybrid_engine.passes.denoise.denoise.LINEAR_LEVELS", levels)
        found[levels] = bias_beside_the_step(renderer, scene, camera, clean, beside, frames=16)
    assert abs(found[denoise.LINEAR_LEVELS]) < abs(found[1]) / 2, found


# -- end to end ------------------------------------------------------------------------------
def corner_scene(mirror: bool = False) -> SceneData:
    """A floor against a wall with a box on it, lit by a white World only (so the
    sky's visibility the rays find is the noisy part); ``mirror`` makes the wall a mirror
    (and leaves the box out, whose front faces as the wall does)."""
    objects = [(quad((0, 0, 0), (10, 0, 0), (0, 10, 0)), None, 0), (quad((0, 2, 2), (10, 0, 0), (0, 0, 2)), None, 1)]
    if not mirror:
        objects.append((box((-1.6, -0.2, 0), (-0.6, 0.8, 1.0)), None, 0))
    rows = [dict(base_color=(0.8, 0.8, 0.8)),
            dict(base_color=(0.9, 0.9, 0.9), reflectivity=1.0, roughness=0.0) if mirror
            else dict(base_color=(0.7, 0.5, 0.4))]
    return SceneData(Geometry.from_objects(objects), MaterialTable.from_rows(rows), Lights.empty(),
                     Sky(color=(1.0, 1.0, 1.0)))


CORNER_CAMERA = Camera(matrix_world=look_at((0.5, -4.0, 1.6), (0.0, 1.0, 0.6)), width=80, height=60)
RAYS = RenderSettings(mode="FULL_BVH", shadow_resolution=256, world_light="RAYS")


def test_denoised_frames_of_traced_world_light_are_near_the_converged_image(renderer):
    """The World's light gathered by one ray per pixel: one denoised frame is much closer to
    the mean of 32 undenoised frames than one undenoised frame is, and a few more frames of
    a still camera (the denoiser's history, not the film) closer still."""
    scene = corner_scene()
    converged = np.mean([renderer.render(scene, CORNER_CAMERA, RAYS, sample=k).image[..., :3] for k in range(32)],
                        axis=0)
    plain = renderer.render(scene, CORNER_CAMERA, RAYS, sample=40).image[..., :3]
    denoised = [renderer.render(scene, CORNER_CAMERA, RAYS, sample=40 + k, denoise=True).image[..., :3]
                for k in range(6)]
    error = lambda image: float(np.sqrt(np.mean((image - converged) ** 2)))  # noqa: E731
    assert error(denoised[0]) < 0.5 * error(plain), (error(denoised[0]), error(plain))
    assert error(denoised[-1]) < 0.9 * error(denoised[0]), (error(denoised[-1]), error(denoised[0]))


def test_a_mirror_is_never_blurred(renderer):
    """The wall is a perfect mirror: its pixels are the tracer's reflection, which is not in
    the ambient estimate, so they are the same bit for bit with and without the denoiser,
    while the floor's diffuse light is filtered."""
    scene = corner_scene(mirror=True)
    plain = renderer.render(scene, CORNER_CAMERA, RAYS, sample=5).image
    denoised = renderer.render(scene, CORNER_CAMERA, RAYS, sample=5, denoise=True).image
    depth = renderer.render(scene, CORNER_CAMERA, RAYS, sample=5, outputs=FrameOutputs(normal=True))
    normals = depth.data_passes["normal"]
    mirror = np.abs(normals[..., 1]) > 0.99  # the wall faces -y; floor and box tops face +z
    floor = normals[..., 2] > 0.99
    assert mirror.sum() > 200 and floor.sum() > 200
    np.testing.assert_array_equal(denoised[mirror], plain[mirror])
    # The floor's light was filtered. (Its paths go on in the mirror to the sky, so one
    # sample of it is already smooth: the filter moves it by a few hundredths.)
    assert np.abs(denoised[floor] - plain[floor]).max() > 0.02


def test_a_denoised_final_render_does_not_depend_on_what_the_renderer_drew_before(renderer):
    """A final render's samples start the denoiser's history over: the same render twice,
    with another view between, gives the same image."""
    scene = corner_scene()
    first = render_antialiased(renderer, scene, CORNER_CAMERA, RAYS, 3, denoise=True).image
    renderer.render(scene, Camera(matrix_world=look_at((2.0, -3.0, 2.0), (0, 1, 0.5)), width=80, height=60), RAYS,
                    denoise=True)
    again = render_antialiased(renderer, scene, CORNER_CAMERA, RAYS, 3, denoise=True).image
    np.testing.assert_array_equal(first, again)


# -- the film's mean of a still view -----------------------------------------------------------
def still_floor() -> tuple[SceneData, Camera]:
    floor = SceneData(Geometry.from_objects([(quad((0, 0, 0), (20, 0, 0), (0, 20, 0)), None, 0)]), grey(),
                      Lights.empty(), Sky(color=(1.0, 1.0, 1.0)))
    return floor, Camera(matrix_world=look_at((0.0, -5.0, 4.0), (0.0, 0.0, 0.0)), width=64, height=48)


def test_a_still_views_film_shows_the_latest_filtered_estimate_not_the_mean_of_them(renderer, probe):
    """The temporal blend of a still view's first frames is already the mean of all of them:
    the film's mean of the viewport's samples is the last denoised frame itself, not the mean
    of the filtered means (which counts the first, noisiest frames most)."""
    scene, camera = still_floor()
    probe(pattern=0, noise=0.6)
    renderer.render(scene, camera, RASTER)  # undenoised: the history starts over
    for k in range(8):
        film = renderer.render(scene, camera, RASTER, sample=k, accumulate=True, denoise=True).image[..., :3]
    renderer.render(scene, camera, RASTER)
    for k in range(8):
        alone = renderer.render(scene, camera, RASTER, sample=k, denoise=True).image[..., :3]
    np.testing.assert_allclose(film, alone, atol=2e-4)


