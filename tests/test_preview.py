# SPDX-License-Identifier: GPL-3.0-or-later
"""Material, World and Light previews (blender_adapter/preview.py), rendered by Blender's own
preview job (``bpy.ops.ed.lib_id_generate_preview``), which calls the engine's ``render()``
with ``is_preview`` on a job thread, and the GL hand-over between that thread and the main
thread's viewport frames (hybrid_engine/gpu/gl_context.py).

Without an event loop the job never reports that it finished, so the tests wait for the
preview's pixels to arrive. The main thread of a background session keeps the GL context
current between its blocks; while it waits it hands the context over (``hand_back``).
"""
from __future__ import annotations

import threading
import time

import numpy as np
import pytest

PREVIEW_TIMEOUT_S = 180.0  # the first preview of a process compiles the passes' shaders
WIDTH, HEIGHT = 24, 16
RED, BLUE, GREEN = (0.8, 0.05, 0.05, 1.0), (0.05, 0.05, 0.8, 1.0), (0.05, 0.6, 0.05, 1.0)


def generate_preview(bpy, id_data, *, wait_idle=True) -> np.ndarray:
    """Start Blender's preview job for ``id_data`` and return its pixels, (128, 128, 4), row 0
    at the bottom. ``wait_idle``: the main thread only waits (it hands the GL context over);
    otherwise the caller keeps rendering and waits with ``wait_for_preview``."""
    from hybrid_engine.gpu import gl_context

    id_data.preview_ensure()
    pixels = id_data.preview.image_pixels_float
    pixels.foreach_set(np.zeros(len(pixels), np.float32))
    with bpy.context.temp_override(id=id_data):
        bpy.ops.ed.lib_id_generate_preview()
    if not wait_idle:
        return None
    gl_context.hand_back()
    try:
        return wait_for_preview(id_data)
    finally:
        with gl_context.activated():  # this thread takes the context back for the next tests
            pass


def preview_image(id_data) -> np.ndarray | None:
    """The preview's pixels once any arrived, else None."""
    preview = id_data.preview
    pixels = np.array(preview.image_pixels_float[:], np.float32)
    if not pixels.any():
        return None
    width, height = preview.image_size
    return pixels.reshape(height, width, 4)


def wait_for_preview(id_data, timeout: float = PREVIEW_TIMEOUT_S) -> np.ndarray:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        image = preview_image(id_data)
        if image is not None:
            return image
        time.sleep(0.01)
    raise AssertionError(f"no preview of {id_data.name!r} within {timeout:.0f} s")


def red_material(bpy, colour=RED):
    material = bpy.data.materials.new("preview")
    material.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = colour
    return material


def centre(image: np.ndarray) -> np.ndarray:
    """The mean colour of the preview's middle, where the preview object stands."""
    height, width = image.shape[:2]
    return image[height * 3 // 8: height * 5 // 8, width * 3 // 8: width * 5 // 8, :3].reshape(-1, 3).mean(0)


@pytest.fixture
def preview_scene(addon):
    import bpy

    bpy.context.scene.render.engine = "HYBRID_RT"
    return bpy


def test_a_material_preview_renders_through_blenders_preview_job_in_the_materials_colour(preview_scene):
    bpy = preview_scene
    red = centre(generate_preview(bpy, red_material(bpy, RED)))
    blue = centre(generate_preview(bpy, red_material(bpy, BLUE)))
    assert red[0] > 1.5 * red[1] and red[0] > 1.5 * red[2], red
    assert blue[2] > 1.5 * blue[0] and blue[2] > 1.5 * blue[1], blue


def test_a_preview_tells_the_artist_nothing_about_blenders_preview_scene(preview_scene, monkeypatch):
    """Blender's preview scene has a hidden floor whose Alpha reads a Math node, which the
    exporter names when it meets it in the artist's own scenes. In a preview it is Blender's,
    not the artist's: no message may leave the preview uncollected (it would reach the
    console as a warning)."""
    bpy = preview_scene
    messages = preview_scene_module(bpy).messages
    uncollected = []
    original = messages.tell

    def tell(message):
        if not messages.is_collected():
            uncollected.append(message)
        original(message)
    monkeypatch.setattr(messages, "tell", tell)
    generate_preview(bpy, red_material(bpy, RED))
    assert uncollected == []


def test_a_world_preview_shows_the_worlds_colour(preview_scene):
    bpy = preview_scene
    world = bpy.data.worlds.new("preview")
    world.node_tree.nodes["Background"].inputs["Color"].default_value = GREEN
    colour = generate_preview(bpy, world)[..., :3].reshape(-1, 3).mean(0)
    assert colour[1] > 1.5 * colour[0] and colour[1] > 1.5 * colour[2], colour


@pytest.mark.parametrize("kind", ["POINT", "SUN", "SPOT", "AREA"])
def test_a_light_preview_is_lit(preview_scene, kind):
    bpy = preview_scene
    image = generate_preview(bpy, bpy.data.lights.new("preview", kind))
    # Lit, not black: Blender's preview floor is a procedural checker (Math and Checker nodes)
    # that takes much of a spot's light, so the bar is well above black, not a brightness.
    assert image[..., :3].mean() > 0.03, image[..., :3].mean()


def test_a_preview_writes_nothing_to_the_artists_data_and_keeps_f12s_scene(preview_scene):
    """The preview renders Blender's preview scene with its own renderer: the artist's scene
    settings and F12's kept scene are as they were."""
    bpy = preview_scene
    engine = bpy.context.scene.hybrid_rt
    before = {name: getattr(engine, name) for name in engine.bl_rna.properties.keys() if name != "rna_type"}
    final_scenes = dict(preview_scene_module(bpy).engine._final_scenes)
    generate_preview(bpy, red_material(bpy))
    after = {name: getattr(engine, name) for name in engine.bl_rna.properties.keys() if name != "rna_type"}
    assert after == before
    assert preview_scene_module(bpy).engine._final_scenes == final_scenes
    assert preview_scene_module(bpy).engine._renderer is None  # F12's renderer was not made or used


def preview_scene_module(bpy):
    import sys

    return sys.modules["hybrid_rt"].blender_adapter


# ---------------------------------------------------------------------------------------------
# A preview on the job thread while the main thread renders viewport frames.

def _viewport_scene(bpy):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = "RASTER"
    scene.hybrid_rt.shadow_resolution = 128
    scene.hybrid_rt.viewport_samples = 4096  # every frame renders a new sample
    bpy.ops.mesh.primitive_plane_add(size=10)
    bpy.ops.mesh.primitive_cube_add(location=(0, 0, 1))
    cube = bpy.context.object
    cube.data.materials.append(red_material(bpy, BLUE))
    bpy.ops.object.light_add(type="SUN", location=(0, 0, 5))
    return scene


def _viewport_frames(addon, bpy, count: int | None, until=None) -> list[np.ndarray]:
    """Frames of a fresh viewport session: ``count`` of them, or until ``until()`` is true
    (then three more, so the last frames follow the preview's GL work)."""
    from dataclasses import replace

    from hybrid_engine.frame.viewport import RegionInput
    from hybrid_engine.scene.camera import Camera, look_at

    session = addon.blender_adapter.viewport.ViewportSession()
    session.update(bpy.context.evaluated_depsgraph_get(), full=True)
    settings = replace(addon.blender_adapter.properties.settings_from_scene(bpy.context.scene),
                       denoise_viewport=False)
    camera = Camera(matrix_world=look_at((6.0, -7.0, 5.0), (0.0, 0.0, 0.5)), width=WIDTH, height=HEIGHT, lens=35.0)
    region = RegionInput(camera.view_matrix(), camera.projection_matrix(), WIDTH, HEIGHT)
    frames, extra = [], 3
    try:
        while count is None or len(frames) < count:
            frame = session.frame(region, settings)
            assert frame.error is None, frame.error
            frames.append(frame.image.copy())
            if until is not None and until():
                extra -= 1
                if extra == 0:
                    break
            assert len(frames) < 5000, "the preview never arrived"
    finally:
        session.release()
    return frames


def test_a_preview_on_the_job_thread_leaves_the_viewports_frames_bit_identical(addon, monkeypatch):
    import bpy

    preview = addon.blender_adapter.preview
    renders = []
    original = preview.render_preview

    def recorded(depsgraph, cancel=None):
        start = time.perf_counter()
        result = original(depsgraph, cancel)
        renders.append((threading.current_thread() is threading.main_thread(), start, time.perf_counter()))
        return result

    monkeypatch.setattr(preview, "render_preview", recorded)
    _viewport_scene(bpy)
    material = red_material(bpy, RED)
    generate_preview(bpy, material)  # compiles the preview's shaders, so the next overlaps frames
    renders.clear()

    generate_preview(bpy, material, wait_idle=False)
    started = time.perf_counter()
    during = _viewport_frames(addon, bpy, None, until=lambda: preview_image(material) is not None)
    ended = time.perf_counter()
    image = wait_for_preview(material)
    alone = _viewport_frames(addon, bpy, len(during))

    assert len(renders) == 1 and not renders[0][0], "the preview rendered on Blender's job thread"
    assert started < renders[0][2] and renders[0][1] < ended, "the preview ran while the viewport rendered"
    assert len(during) > 3
    for index, (a, b) in enumerate(zip(during, alone)):
        np.testing.assert_array_equal(a, b, err_msg=f"viewport frame {index}")
    red = centre(image)
    assert red[0] > 1.5 * red[1] and red[0] > 1.5 * red[2], red
