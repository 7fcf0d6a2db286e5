# SPDX-License-Identifier: GPL-3.0-or-later
"""The viewport's Blender glue (blender_adapter/viewport.py, scene_cache.py) with the real depsgraph.

Background Blender has no window, so ``view_draw``'s final texture draw cannot run here;
everything before it can. ``depsgraph.updates`` is only filled inside Blender's
``depsgraph_update_post`` and ``frame_change_post`` handlers, so the tests feed the session
from those handlers, exactly as ``view_update`` is fed by Blender in a viewport.
"""
from __future__ import annotations

import gc
import os

import numpy as np
import pytest

from hybrid_engine.scene.camera import look_at

WIDTH, HEIGHT = 24, 16
# Two renders of an unchanged scene are bit-identical; a real change moves many pixels by far more.
IMAGE_CHANGE = 1e-3
# Process RSS may wander by allocator noise between frame 20 and 200; a leak of one 24x16
# frame's GL objects per frame would exceed this many times over.
RSS_GROWTH_LIMIT_BYTES = 24 * 2**20


@pytest.fixture
def viewport(addon, fed_session):
    """The add-on's viewport module with a session fed by depsgraph handlers."""
    session, reports = fed_session
    return addon.blender_adapter.viewport, session, reports


def _region(bpy, eye=(6.0, -7.0, 5.0), target=(0.0, 0.0, 0.5)):
    from hybrid_engine.scene.camera import Camera
    from hybrid_engine.frame.viewport import RegionInput

    camera = Camera(matrix_world=look_at(eye, target), width=WIDTH, height=HEIGHT, lens=35.0)
    return RegionInput(camera.view_matrix(), camera.projection_matrix(), WIDTH, HEIGHT)


def _settings(addon, bpy):
    """The scene's settings, without the viewport's denoiser: these tests compare frames
    that should be equal bit for bit, and its history (which follows the view from frame to
    frame by design, tests/test_denoise.py) would carry earlier frames into later ones."""
    from dataclasses import replace

    return replace(addon.blender_adapter.properties.settings_from_scene(bpy.context.scene), denoise_viewport=False)


def _sync(bpy):
    """Let Blender evaluate pending changes (runs the depsgraph_update_post handlers)."""
    bpy.context.evaluated_depsgraph_get()


def _two_object_scene(bpy):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.hybrid_rt.mode = "RASTER"
    scene.hybrid_rt.shadow_resolution = 128
    bpy.ops.mesh.primitive_plane_add(size=10)
    bpy.ops.mesh.primitive_cube_add(location=(0, 0, 1))
    cube = bpy.context.object
    material = bpy.data.materials.new("red")
    material.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.9, 0.1, 0.1, 1)
    cube.data.materials.append(material)
    bpy.ops.object.light_add(type="SUN", location=(0, 0, 5))
    return scene, cube, material


def _kept(frame):
    """``frame`` with its own copy of the image (a frame's image is the session's read-back
    array, refilled by the next frame)."""
    from dataclasses import replace

    return replace(frame, image=None if frame.image is None else frame.image.copy())


def _frame(addon, bpy, session):
    frame = session.frame(_region(bpy), _settings(addon, bpy))
    assert frame.error is None, frame.error
    return _kept(frame)


def test_moving_one_object_re_extracts_only_that_object_and_changes_the_image(addon, viewport):
    import bpy

    _module, session, reports = viewport
    _scene, cube, _material = _two_object_scene(bpy)
    _sync(bpy)
    assert {name for report in reports for name in report.extracted} == {"Plane", "Cube"}
    before = _frame(addon, bpy, session).image
    reports.clear()

    cube.location.x += 1.5
    _sync(bpy)
    report = reports[-1]
    assert report.extracted == []  # no mesh was read again
    assert report.transformed == ["Cube"] and report.reused == 1  # the plane's arrays were kept
    after = _frame(addon, bpy, session).image
    assert np.abs(after - before).max() > IMAGE_CHANGE

    reports.clear()
    bpy.context.scene.hybrid_rt.viewport_samples = 1  # one sample: a still view is not re-rendered
    _sync(bpy)  # nothing changed: nothing is redone and the image stays
    assert not reports or (reports[-1].extracted == [] and reports[-1].transformed == [])
    np.testing.assert_array_equal(_frame(addon, bpy, session).image, after)


def test_transparent_film_leaves_the_viewports_background_transparent(addon, viewport):
    import bpy

    _module, session, _reports = viewport
    _two_object_scene(bpy)
    _sync(bpy)
    opaque = _frame(addon, bpy, session).image
    clear = session.frame(_region(bpy), _settings(addon, bpy), transparent=True).image
    background = clear[..., 3] == 0
    assert (opaque[..., 3] == 1).all()
    assert background.sum() > 10 and (~background).sum() > 10, "the view shows sky and objects"
    assert (clear[background] == 0).all()
    np.testing.assert_array_equal(clear[~background], opaque[~background])


def test_editing_a_material_changes_the_next_frame(addon, viewport):
    """Base colour (a node edit, reported as a Material update) changes the image;
    thickness (set from a script, which Blender does not report) reaches the next frame's
    material table."""
    import bpy

    _module, session, reports = viewport
    _scene, _cube, material = _two_object_scene(bpy)
    _sync(bpy)
    before = _frame(addon, bpy, session).image
    material.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.1, 0.2, 0.9, 1)
    _sync(bpy)
    assert reports[-1].materials_refreshed >= 1 and reports[-1].extracted == []
    after = _frame(addon, bpy, session).image
    assert np.abs(after - before).max() > IMAGE_CHANGE

    index = session.cache.scene_data.materials.names.index("red")
    old_thickness = float(session.cache.scene_data.materials.thickness[index])
    material.hybrid_rt.thickness = 0.25 if old_thickness != 0.25 else 0.75
    session.update(bpy.context.evaluated_depsgraph_get())  # what the next view_update does
    assert session.cache.scene_data.materials.thickness[index] == pytest.approx(material.hybrid_rt.thickness)
    _frame(addon, bpy, session)


def _deformed_scene(bpy):
    """Three meshes deformed three ways over frames 1..10: an armature, a shape key and a
    time-dependent modifier (Wave)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.hybrid_rt.mode = "RASTER"
    scene.hybrid_rt.shadow_resolution = 128
    scene.frame_start, scene.frame_end = 1, 200

    # Armature: a bone rotating a subdivided column bound with automatic-free vertex groups.
    bpy.ops.mesh.primitive_cylinder_add(vertices=8, depth=2, location=(-2.5, 0, 1))
    column = bpy.context.object
    column.name = "Skinned"
    group = column.vertex_groups.new(name="Bone")
    group.add([v.index for v in column.data.vertices if v.co.z > 0], 1.0, "REPLACE")
    armature_data = bpy.data.armatures.new("Rig")
    rig = bpy.data.objects.new("Rig", armature_data)
    scene.collection.objects.link(rig)
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode="EDIT")
    bone = armature_data.edit_bones.new("Bone")
    bone.head, bone.tail = (-2.5, 0, 1), (-2.5, 0, 2)
    bpy.ops.object.mode_set(mode="OBJECT")
    column.modifiers.new("Armature", "ARMATURE").object = rig
    pose_bone = rig.pose.bones["Bone"]
    pose_bone.rotation_mode = "XYZ"
    for frame, angle in ((1, 0.0), (200, 6.0)):
        pose_bone.rotation_euler = (angle, 0, 0)
        pose_bone.keyframe_insert("rotation_euler", frame=frame)

    # Shape key animated from 0 to 1.
    bpy.ops.mesh.primitive_cube_add(location=(0, 0, 1))
    keyed = bpy.context.object
    keyed.name = "ShapeKeyed"
    keyed.shape_key_add(name="Basis")
    key = keyed.shape_key_add(name="Stretch")
    for point in key.data:
        point.co.z *= 2.0
    for frame, value in ((1, 0.0), (200, 1.0)):
        key.value = value
        key.keyframe_insert("value", frame=frame)

    # A modifier that depends on time.
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=8, y_subdivisions=8, size=3, location=(2.5, 0, 0.5))
    waved = bpy.context.object
    waved.name = "Waved"
    wave = waved.modifiers.new("Wave", "WAVE")
    wave.height, wave.width, wave.speed = 0.5, 1.0, 0.1

    bpy.ops.mesh.primitive_plane_add(size=12)
    bpy.ops.object.light_add(type="SUN", location=(0, 0, 5))
    scene.frame_set(1)
    return scene


def _object_triangles(session, name):
    geometry = session.cache.scene_data.geometry
    k = geometry.object_names.index(name)
    first, count = geometry.object_ranges[k]
    return geometry.triangles[first:first + count].copy()


DEFORMED = ("Skinned", "ShapeKeyed", "Waved")


def test_frame_change_picks_up_armature_shape_key_and_modifier_deformation(addon, viewport):
    import bpy

    _module, session, reports = viewport
    scene = _deformed_scene(bpy)
    _sync(bpy)
    before = {name: _object_triangles(session, name) for name in DEFORMED}
    image_before = _frame(addon, bpy, session).image
    reports.clear()

    scene.frame_set(40)
    assert reports, "a frame change must reach the session"
    assert set(DEFORMED) <= set(reports[-1].extracted)
    assert "Plane" not in reports[-1].extracted  # static geometry stays cached
    for name in DEFORMED:
        after = _object_triangles(session, name)
        assert after.shape == before[name].shape
        assert np.abs(after - before[name]).max() > 1e-3, f"{name} did not deform"
    assert np.abs(_frame(addon, bpy, session).image - image_before).max() > IMAGE_CHANGE


def _rss_bytes() -> int:
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def _live_gl_objects() -> int:
    """moderngl objects that have not been released."""
    import moderngl

    kinds = (moderngl.Buffer, moderngl.Texture, moderngl.Framebuffer, moderngl.VertexArray,
             moderngl.Renderbuffer, moderngl.Query)
    return sum(1 for obj in gc.get_objects()
               if isinstance(obj, kinds) and type(getattr(obj, "mglo", None)).__name__ != "InvalidObject")


@pytest.mark.skipif(not os.path.exists("/proc/self/statm"), reason="RSS is read from /proc (Linux)")
def test_two_hundred_frames_of_playback_keep_gl_objects_and_memory_stable(addon, viewport):
    """Playback: every frame re-extracts the deformed meshes and renders; nothing accumulates."""
    import bpy

    _module, session, reports = viewport
    scene = _deformed_scene(bpy)
    _sync(bpy)
    region, settings = _region(bpy), _settings(addon, bpy)
    gl = session._ensure_renderer().ctx
    marks = {}
    for frame in range(1, 201):
        scene.frame_set(frame)
        result = session.frame(region, settings)
        assert result.error is None, result.error
        if frame in (20, 200):
            gc.collect()
            probe = gl.buffer(reserve=4)  # GL names are reused: a leak makes them climb
            marks[frame] = (_live_gl_objects(), _rss_bytes(), probe.glo)
            probe.release()
    assert set(DEFORMED) <= set(reports[-1].extracted)
    (objects_20, rss_20, name_20), (objects_200, rss_200, name_200) = marks[20], marks[200]
    assert objects_200 == objects_20
    assert name_200 <= name_20 + 2
    assert rss_200 - rss_20 < RSS_GROWTH_LIMIT_BYTES, f"RSS grew {(rss_200 - rss_20) / 2**20:.1f} MiB"
    assert "fps" in result.stats and "tris" in result.stats


def test_an_error_inside_a_frame_is_reported_once_and_the_next_frame_renders(addon, viewport, capsys, monkeypatch):
    import bpy

    _module, session, _reports = viewport
    _two_object_scene(bpy)
    _sync(bpy)
    renderer = session._ensure_renderer()
    real_render = renderer.render
    calls = {"n": 0}

    def failing_twice(*args, **kwargs):
        calls["n"] += 1
        if calls["n"] <= 2:
            raise RuntimeError("simulated driver failure")
        return real_render(*args, **kwargs)

    monkeypatch.setattr(renderer, "render", failing_twice)
    first = _kept(session.frame(_region(bpy), _settings(addon, bpy)))
    second = _kept(session.frame(_region(bpy), _settings(addon, bpy)))
    assert first.error and "simulated driver failure" in first.error and first.image is None
    assert second.error == first.error
    assert first.stats == first.error  # the header shows it too
    assert capsys.readouterr().out.count("simulated driver failure") == 1  # console: once
    third = session.frame(_region(bpy), _settings(addon, bpy))
    assert third.error is None and third.image.shape == (HEIGHT, WIDTH, 4)


def test_missing_opengl_is_a_clear_message_not_an_exception(addon, capsys):
    import bpy
    from hybrid_engine.gpu.gl_context import GLUnavailableError

    def no_gl():
        raise GLUnavailableError("Hybrid RT needs OpenGL 4.3 (compute shaders); the driver offers 3.3")

    module = addon.blender_adapter.viewport
    session = module.ViewportSession(renderer_factory=no_gl)
    session.update(bpy.context.evaluated_depsgraph_get())
    frames = [session.frame(_region(bpy), _settings(addon, bpy)) for _ in range(3)]
    assert all(f.error and "OpenGL 4.3" in f.error for f in frames)
    assert capsys.readouterr().out.count("OpenGL 4.3") == 1


def test_callback_errors_reach_the_header_every_time_and_the_console_once(addon, capsys):
    module = addon.blender_adapter.viewport

    class FakeEngine:
        def __init__(self):
            self.stats, self.reports = [], []

        def update_stats(self, _title, text):
            self.stats.append(text)

        def report(self, level, text):
            self.reports.append((level, text))

    engine = FakeEngine()
    for _ in range(3):
        module.callback_failed(engine, "view_draw", ValueError("region has no 3D view data"))
    assert len(engine.stats) == 3 and "region has no 3D view data" in engine.stats[0]
    assert len(engine.reports) == 1
    assert capsys.readouterr().err.count("region has no 3D view data") == 1  # one traceback


def test_engine_has_viewport_callbacks_and_sessions_are_freed(addon, viewport):
    import bpy

    module, _session, _reports = viewport
    engine_class = addon.blender_adapter.engine.HybridRTRenderEngine
    assert callable(engine_class.view_update) and callable(engine_class.view_draw)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    shared = module.session_for(depsgraph)
    assert module.session_for(depsgraph) is shared
    shared.update(depsgraph)
    shared._ensure_renderer()
    module.release_all()
    assert shared.renderer is None and not shared.cache.synced
    assert module.session_for(depsgraph) is not shared


def test_near_cube_overlay_is_a_saved_setting_and_surrounds_the_eye(addon, tmp_path):
    import bpy
    from mathutils import Matrix

    overlay = addon.operators.near_cube_overlay
    scene = bpy.context.scene
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.near_size = 2.5
    assert not overlay.is_shown(scene) and overlay._handle is not None  # drawn only when asked
    scene.hybrid_rt.show_near_cube = True
    path = tmp_path / "overlay.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    assert not overlay.is_shown(bpy.context.scene)
    bpy.ops.wm.open_mainfile(filepath=str(path))
    scene = bpy.context.scene
    assert overlay.is_shown(scene)  # saved with the file

    # Without a viewport (and in camera view) the cube surrounds the scene camera.
    edges = overlay.overlay_edges(scene)
    camera_position = np.array(scene.camera.matrix_world.translation)
    np.testing.assert_allclose(edges.reshape(-1, 3).mean(axis=0), camera_position, atol=1e-5)
    np.testing.assert_allclose(np.abs(edges.reshape(-1, 3) - camera_position), 2.5, atol=1e-5)

    class RegionData:  # the two RegionView3D attributes the overlay reads
        view_perspective = "PERSP"
        view_matrix = Matrix(look_at((1.0, 2.0, 3.0), (0.0, 0.0, 0.0)).tolist()).inverted()

    edges = overlay.overlay_edges(scene, RegionData())
    np.testing.assert_allclose(edges.reshape(-1, 3).mean(axis=0), (1.0, 2.0, 3.0), atol=1e-5)
    # With Frame Budget the cube drawn is the size the budget holds within its limits.
    scene.hybrid_rt.near_cube_mode = "BUDGET"
    scene.hybrid_rt.near_min, scene.hybrid_rt.near_max = 0.5, 1.0
    edges = overlay.overlay_edges(scene)
    np.testing.assert_allclose(np.abs(edges.reshape(-1, 3) - camera_position), 1.0, atol=1e-5)


def _accumulating(bpy, session, monkeypatch, samples: int):
    """The two-object scene with ``samples`` viewport samples, synced; returns the scene, the
    cube and the list that records the sample index of every render the session makes."""
    scene, cube, _material = _two_object_scene(bpy)
    scene.hybrid_rt.viewport_samples = samples
    _sync(bpy)
    return scene, cube, _count_renders(session, monkeypatch)


def _count_renders(session, monkeypatch) -> list:
    renderer = session._ensure_renderer()
    calls = []
    original = renderer.render

    def counted(*args, **kwargs):
        calls.append(kwargs.get("sample"))
        return original(*args, **kwargs)

    monkeypatch.setattr(renderer, "render", counted)
    return calls


def test_still_redraws_accumulate_samples_up_to_viewport_samples_then_render_nothing(addon, viewport, monkeypatch):
    import bpy

    _module, session, _reports = viewport
    _scene, _cube, calls = _accumulating(bpy, session, monkeypatch, 4)
    frames = [_frame(addon, bpy, session) for _ in range(6)]
    assert calls == [0, 1, 2, 3]  # one new sample per redraw, then none
    assert [f.converged for f in frames] == [False, False, False, True, True, True]
    assert "sample 1/4" in frames[0].stats and "sample 4/4" in frames[3].stats
    assert np.abs(frames[1].image - frames[0].image).max() > 0  # the jittered sample joined the mean
    np.testing.assert_array_equal(frames[5].image, frames[3].image)


def test_accumulation_restarts_when_the_view_an_object_or_a_setting_changes(addon, viewport, monkeypatch):
    import bpy

    _module, session, _reports = viewport
    scene, cube, calls = _accumulating(bpy, session, monkeypatch, 8)
    settings = _settings(addon, bpy)
    for _ in range(3):
        session.frame(_region(bpy), settings)
    session.frame(_region(bpy, eye=(6.0, -7.5, 5.0)), settings)  # the view moved
    session.frame(_region(bpy, eye=(6.0, -7.5, 5.0)), settings)
    cube.location.z += 0.5  # an object moved
    _sync(bpy)
    session.frame(_region(bpy, eye=(6.0, -7.5, 5.0)), settings)
    scene.hybrid_rt.shadow_bias = 0.05  # a setting changed
    _sync(bpy)
    session.frame(_region(bpy, eye=(6.0, -7.5, 5.0)), _settings(addon, bpy))
    assert calls == [0, 1, 2, 0, 1, 0, 0]


def test_sixteen_still_redraws_converge_to_a_64_sample_final_render_of_the_view(addon, viewport):
    import bpy

    from hybrid_engine.frame.antialias import render_antialiased
    from hybrid_engine.frame.viewport import RegionInput
    from whitted_reference import flip_mean

    _module, session, _reports = viewport
    scene, cube, material = _two_object_scene(bpy)
    scene.hybrid_rt.mode = "HYBRID"
    bsdf = material.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Metallic"].default_value = 1.0
    bsdf.inputs["Roughness"].default_value = 0.3  # a glossy lobe: noisy in one sample
    scene.hybrid_rt.viewport_samples = 16
    _sync(bpy)
    from hybrid_engine.scene.camera import Camera

    camera = Camera(matrix_world=look_at((4.0, -5.0, 3.5), (0.0, 0.0, 0.7)), width=64, height=48, lens=35.0)
    region = RegionInput(camera.view_matrix(), camera.projection_matrix(), 64, 48)
    settings = _settings(addon, bpy)
    frames = [_kept(session.frame(region, settings)) for _ in range(16)]
    assert frames[-1].converged and not frames[-2].converged
    from hybrid_engine.frame.viewport import plan_frame

    reference = render_antialiased(session.renderer, session.cache.scene_data, plan_frame(region, 1.0).view,
                                   settings, 64, timing=False).image
    first = flip_mean(reference[..., :3], frames[0].image[..., :3])
    last = flip_mean(reference[..., :3], frames[-1].image[..., :3])
    assert last < 0.02, (first, last)
    assert last < 0.5 * first, (first, last)


def test_frame_budget_sizes_the_viewports_near_cube_and_f12_takes_the_size_it_settled_on(addon):
    """Navigating (every redraw a new view) with an unreachable budget shrinks the near cube
    to its minimum, shown in the stats line; a final render then uses that size."""
    import bpy

    module = addon.blender_adapter.viewport
    scene, _cube, _material = _two_object_scene(bpy)
    scene.hybrid_rt.mode = "HYBRID"
    scene.hybrid_rt.cube_resolution = 32
    scene.hybrid_rt.near_cube_mode = "BUDGET"
    scene.hybrid_rt.near_min, scene.hybrid_rt.near_max, scene.hybrid_rt.near_size = 0.5, 4.0, 2.0
    scene.hybrid_rt.frame_budget_ms = 0.001
    depsgraph = bpy.context.evaluated_depsgraph_get()
    session = module.session_for(depsgraph)  # the session view_draw would use
    try:
        session.update(depsgraph, full=True)
        for step in range(12):
            frame = session.frame(_region(bpy, eye=(6.0 + 0.01 * step, -7.0, 5.0)), _settings(addon, bpy))
            assert frame.error is None, frame.error
        assert session.sizer.size == pytest.approx(0.5)
        assert "near 0.50" in frame.stats
        camera = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
        scene.collection.objects.link(camera)
        scene.camera = camera
        camera.location, camera.rotation_euler = (6.0, -7.0, 5.0), (1.0, 0.0, 0.7)
        scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 16, 12, 100
        scene.render.engine = "HYBRID_RT"
        bpy.ops.render.render()
        assert addon.blender_adapter.engine.last_frame.near_size == pytest.approx(0.5)
    finally:
        module.release_all()


def test_a_diagnostic_view_shows_its_legend_in_the_viewport(addon, viewport):
    import bpy
    from hybrid_engine.passes.trace import diagnostic_views
    from hybrid_engine.reports import diagnostic_legend

    _module, session, _reports = viewport
    scene, _cube, _material = _two_object_scene(bpy)
    scene.hybrid_rt.mode = "BOUNCES"
    _sync(bpy)
    settings = _settings(addon, bpy)
    image = _frame(addon, bpy, session).image
    top_left = image[::-1][:16, :24, :3].reshape(-1, 3)  # rows from the top
    assert np.allclose(top_left[0], diagnostic_legend.LEGEND_BACKGROUND)
    first = diagnostic_views.legend(settings)[0]
    assert np.isclose(top_left, first.colour, atol=1e-6).all(axis=1).any(), first.label


def _count_reads(monkeypatch) -> dict:
    """Count every host read of GL data (buffer, texture and framebuffer reads) and every
    ctx.finish(), by wrapping moderngl's classes."""
    import moderngl

    counts = {"reads": 0, "finish": 0}

    def counting(cls, name, key):
        original = getattr(cls, name)

        def wrapper(self, *args, **kwargs):
            counts[key] += 1
            return original(self, *args, **kwargs)

        monkeypatch.setattr(cls, name, wrapper)

    for cls in (moderngl.Buffer, moderngl.Texture, moderngl.Framebuffer):
        for name in ("read", "read_into"):
            counting(cls, name, "reads")
    counting(moderngl.Context, "finish", "finish")
    return counts


@pytest.mark.parametrize("mode", ["RASTER", "HYBRID", "FULL_BVH"])
def test_a_viewport_redraw_reads_back_exactly_one_image_and_never_waits(addon, viewport, monkeypatch, mode):
    """Each accumulating redraw (first samples, which build the world, and later ones, which
    keep it) brings one image to the host and syncs nowhere else."""
    import bpy

    _module, session, _reports = viewport
    scene, _cube, material = _two_object_scene(bpy)
    material.node_tree.nodes["Principled BSDF"].inputs["Metallic"].default_value = 1.0  # the trace has work
    material.node_tree.nodes["Principled BSDF"].inputs["Roughness"].default_value = 0.0
    scene.hybrid_rt.mode = mode
    scene.hybrid_rt.viewport_samples = 4
    _sync(bpy)
    _frame(addon, bpy, session)  # compiles and sizes everything once, and reads the counts
    session.stats_refresh._clock = lambda: session.stats_refresh._last  # the header is not due again
    counts = _count_reads(monkeypatch)
    per_redraw = []
    for eye in ((6.0, -7.0, 5.0), (6.0, -7.0, 5.0), (6.5, -7.0, 5.0), (6.5, -7.0, 5.0)):
        counts["reads"] = counts["finish"] = 0
        frame = session.frame(_region(bpy, eye=eye), _settings(addon, bpy))
        assert frame.error is None, frame.error
        per_redraw.append((counts["reads"], counts["finish"]))
    assert per_redraw == [(1, 0)] * 4


def test_the_header_takes_the_gpus_counts_only_when_it_refreshes(addon, viewport, monkeypatch):
    """A redraw whose header is due reads the statistics too (one more read-back, after the
    image's frame ran), and its line shows the BVH's triangles; between refreshes the line
    keeps the last counts and the redraw reads only its image."""
    import bpy

    _module, session, _reports = viewport
    scene, _cube, _material = _two_object_scene(bpy)
    scene.hybrid_rt.mode = "HYBRID"
    scene.hybrid_rt.viewport_samples = 8
    _sync(bpy)
    now = [0.0]
    session.stats_refresh._clock = lambda: now[0]
    counts = _count_reads(monkeypatch)
    reads = []
    lines = []
    for step in range(4):
        now[0] = 0.3 * step  # due at 0.0 and 0.6 (every 0.5 s)
        counts["reads"] = 0
        frame = session.frame(_region(bpy, eye=(6.0 + 0.1 * step, -7.0, 5.0)), _settings(addon, bpy))
        assert frame.error is None, frame.error
        reads.append(counts["reads"])
        lines.append(frame.stats)
    assert reads == [2, 1, 2, 1]
    bvh = int(frame.counts["triangles_bvh"])
    assert bvh > 0 and f"BVH {bvh:,} /" in lines[-1] and lines[1].split("| BVH")[1] == lines[0].split("| BVH")[1]


def test_the_asynchronous_read_back_shows_every_sample_at_most_one_redraw_late_and_ends_on_the_mean(
        addon, viewport, monkeypatch):
    """With the pixel-buffer read-back (a GPU's shape), the viewport keeps asking for redraws
    until the last sample's mean has reached the host, and ends on the same image as the
    synchronous read-back."""
    import bpy

    _module, session, _reports = viewport
    scene, _cube, _material = _two_object_scene(bpy)
    scene.hybrid_rt.viewport_samples = 3
    _sync(bpy)

    def converge(family: str) -> tuple[list, np.ndarray]:
        monkeypatch.setenv("HYBRID_RT_KERNELS", f"readback={family}")
        session.release()  # a new renderer and read-back in the chosen shape
        session.update(bpy.context.evaluated_depsgraph_get(), full=True)
        flags = []
        for _ in range(8):
            frame = session.frame(_region(bpy), _settings(addon, bpy))
            flags.append(frame.converged)
            if frame.converged:
                break
        assert session.readback.asynchronous == (family == "gpu")
        return flags, frame.image.copy()

    sync_flags, sync_image = converge("cpu")
    async_flags, async_image = converge("gpu")
    assert sync_flags == [False, False, True]
    assert async_flags[-1] and len(async_flags) in (3, 4)  # the last mean may come one redraw later
    np.testing.assert_array_equal(async_image, sync_image)


def test_the_viewport_denoises_as_its_setting_says(addon, viewport):
    import bpy
    from dataclasses import replace

    _module, session, _reports = viewport
    _two_object_scene(bpy)
    _sync(bpy)
    settings = addon.blender_adapter.properties.settings_from_scene(bpy.context.scene)
    assert settings.denoise_viewport  # on by default
    session.frame(_region(bpy), replace(settings, denoise_viewport=False))
    assert session.renderer.denoiser is None
    frame = session.frame(_region(bpy), settings)
    assert frame.error is None, frame.error
    assert session.renderer.denoiser is not None and session.renderer.denoiser.history.valid


def test_a_grabbed_object_keeps_its_denoiser_history_where_it_moved_off_its_old_place(addon, viewport):
    """Grabbing the cube past its own width between two redraws: the viewport's denoiser
    finds its pixels' history through the object's move (passes/surface_motion/), where the
    camera's reprojection alone lands on the floor it left."""
    import bpy

    _module, session, _reports = viewport
    _scene, cube, _material = _two_object_scene(bpy)
    _sync(bpy)
    settings = addon.blender_adapter.properties.settings_from_scene(bpy.context.scene)
    assert settings.denoise_viewport
    for _ in range(3):
        frame = session.frame(_region(bpy), settings)
        assert frame.error is None, frame.error
    cube.location.x += 2.5
    _sync(bpy)
    frame = session.frame(_region(bpy), settings)
    assert frame.error is None, frame.error
    renderer = session.renderer
    moved = renderer.surface_motion.read()[..., 3] > 0  # the cube's pixels, marked with its move
    lengths = renderer.denoiser.history.read("length")[..., 0]
    assert moved.sum() > 30
    assert (lengths[moved] > 1).mean() > 0.8, np.unique(lengths[moved], return_counts=True)


def test_a_shape_key_moving_the_cube_keeps_its_denoiser_history_where_it_moved_off_its_old_place(addon, viewport):
    """A shape key moves the cube's vertices past its width between two redraws (its matrix
    stays): the scene sync sends the deformed mesh as a new version of the same one, the
    instance transform keeps its rows of the redraw before, and the viewport's denoiser finds
    the cube's pixels' history there."""
    import bpy

    _module, session, _reports = viewport
    _scene, cube, _material = _two_object_scene(bpy)
    cube.shape_key_add(name="Basis")
    slide = cube.shape_key_add(name="Slide")
    for point in slide.data:
        point.co.x += 2.5
    slide.value = 0.0
    _sync(bpy)
    settings = addon.blender_adapter.properties.settings_from_scene(bpy.context.scene)
    for _ in range(3):
        frame = session.frame(_region(bpy), settings)
        assert frame.error is None, frame.error
    slide.value = 1.0
    _sync(bpy)
    frame = session.frame(_region(bpy), settings)
    assert frame.error is None, frame.error
    renderer = session.renderer
    moved = renderer.surface_motion.read()[..., 3] > 0
    lengths = renderer.denoiser.history.read("length")[..., 0]
    assert moved.sum() > 30
    assert (lengths[moved] > 1).mean() > 0.8, np.unique(lengths[moved], return_counts=True)


def test_still_viewport_redraws_fill_the_radiance_cache_and_a_recoloured_or_grabbed_object_empties_it(
        addon, viewport):
    """The cache (passes/diffuse_light/radiance_cache.py) through the viewport's own path: a
    still view's redraws keep the scene sync's frames unchanged, so its cells fill from the
    second denoised redraw on; changing a material's colour empties them, and so does
    moving an object."""
    import bpy

    _module, session, _reports = viewport
    scene, cube, material = _two_object_scene(bpy)
    scene.hybrid_rt.mode = "HYBRID"
    _sync(bpy)
    settings = addon.blender_adapter.properties.settings_from_scene(bpy.context.scene)
    assert settings.radiance_cache and settings.denoise_viewport  # on by default
    for _ in range(4):
        frame = session.frame(_region(bpy), settings)
        assert frame.error is None, frame.error
    cells, deposits = session.renderer.diffuse_light.cache.read()
    assert len(cells) > 10 and deposits.sum() > 0
    material.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.1, 0.9, 0.2, 1)
    _sync(bpy)
    frame = session.frame(_region(bpy), settings)
    assert frame.error is None, frame.error
    assert len(session.renderer.diffuse_light.cache.read()[0]) == 0
    for _ in range(2):
        frame = session.frame(_region(bpy), settings)
        assert frame.error is None, frame.error
    assert len(session.renderer.diffuse_light.cache.read()[0]) > 10
    cube.location.x += 0.5
    _sync(bpy)
    frame = session.frame(_region(bpy), settings)
    assert frame.error is None, frame.error
    assert len(session.renderer.diffuse_light.cache.read()[0]) == 0
