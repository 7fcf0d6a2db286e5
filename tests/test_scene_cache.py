# SPDX-License-Identifier: GPL-3.0-or-later
"""The scene cache's kept instance table (blender_adapter/scene_cache.py): rows edited in
place while the instances stay the same, rebuilt when they do not, meshes shared by their
instances and uploaded once, and never an image that differs from a from-scratch sync of
the same frame."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from hybrid_engine.scene.camera import Camera, look_at
from hybrid_engine.frame.viewport import RegionInput

WIDTH, HEIGHT = 32, 20


def _scene(bpy):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.hybrid_rt.mode = "HYBRID"
    scene.hybrid_rt.viewport_samples = 1
    scene.hybrid_rt.shadow_resolution = 128
    scene.hybrid_rt.cube_resolution = 64
    bpy.ops.mesh.primitive_plane_add(size=10)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.6, location=(-1.2, 0, 0.8))
    mirror = bpy.data.materials.new("mirror")
    bsdf = mirror.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Metallic"].default_value = 1.0
    bsdf.inputs["Roughness"].default_value = 0.0
    bpy.context.object.data.materials.append(mirror)
    bpy.ops.mesh.primitive_cube_add(size=0.8, location=(1.0, 0.5, 0.5))
    bpy.ops.object.light_add(type="SUN", location=(0, 0, 5))
    bpy.context.evaluated_depsgraph_get()
    return scene, bpy.data.objects["Cube"]


def _frame(addon, bpy, session):
    camera = Camera(matrix_world=look_at((5.0, -6.0, 4.0), (0.0, 0.0, 0.5)), width=WIDTH, height=HEIGHT, lens=35.0)
    region = RegionInput(camera.view_matrix(), camera.projection_matrix(), WIDTH, HEIGHT)
    # Without the viewport's denoiser: its history carries earlier frames into later ones (by
    # design, tests/test_denoise.py), and these tests compare a session with a new one.
    settings = replace(addon.blender_adapter.properties.settings_from_scene(bpy.context.scene),
                       denoise_viewport=False)
    frame = session.frame(region, settings)
    assert frame.error is None, frame.error
    # A frame's image is the session's read-back array, refilled by its next frame.
    return replace(frame, image=frame.image.copy())


def _from_scratch(addon, bpy):
    """The same frame from a new session that reads the whole scene."""
    session = addon.blender_adapter.viewport.ViewportSession()
    try:
        session.cache.sync(bpy.context.evaluated_depsgraph_get(), full=True)
        return _frame(addon, bpy, session).image
    finally:
        session.release()


def _object_index(session, name):
    return session.cache.scene_data.geometry.object_names.index(name)


def test_moving_one_object_rewrites_and_uploads_only_its_rows(addon, fed_session):
    import bpy

    session, reports = fed_session
    _scene_, cube = _scene(bpy)
    before = _frame(addon, bpy, session).image
    cube.location.x -= 0.4
    cube.rotation_euler.z += 0.6  # normals change too
    bpy.context.evaluated_depsgraph_get()
    assert reports[-1].transformed == ["Cube"] and not reports[-1].rebuilt
    assert not reports[-1].walked  # a known object moved: followed without the walk
    geometry = session.cache.scene_data.geometry
    assert geometry.edit.objects == (_object_index(session, "Cube"),)
    frame = _frame(addon, bpy, session)
    assert session.renderer.gpu_scene.instance_transform.stats.rows_packed == 1  # the producer's word taken
    assert frame.counts["triangles_uploaded"] == 12  # the cube's triangles, nothing else
    # One matrix: no mesh is sent again, and the GPU transforms the cube's 12 triangles.
    assert (frame.counts["instances_written"], frame.counts["meshes_uploaded"],
            frame.counts["triangles_transformed"]) == (1, 0, 12)
    assert np.abs(frame.image - before).max() > 0.05  # the cube is seen where it moved
    np.testing.assert_array_equal(frame.image, _from_scratch(addon, bpy))


def test_deforming_a_mesh_rereads_only_its_positions_and_a_new_topology_rebuilds_it(addon, fed_session,
                                                                                    monkeypatch):
    import bpy

    meshes = addon.blender_adapter.export.meshes
    whole_reads = []
    read_mesh = meshes.read_mesh
    monkeypatch.setattr(meshes, "read_mesh",
                        lambda mesh, *rest: whole_reads.append(mesh.name) or read_mesh(mesh, *rest))
    session, reports = fed_session
    scene, cube = _scene(bpy)
    _frame(addon, bpy, session)
    whole_reads.clear()
    cube.data.vertices[0].co.z += 0.3
    cube.data.update()
    bpy.context.evaluated_depsgraph_get()
    assert reports[-1].extracted == ["Cube"] and not reports[-1].rebuilt
    assert whole_reads == []  # positions and normals only: the topology was kept
    frame = _frame(addon, bpy, session)
    assert (frame.counts["meshes_uploaded"], frame.counts["instances_written"]) == (1, 1)
    assert not session.renderer.gpu_scene.instance_transform.stats.store_rebuilt
    np.testing.assert_array_equal(frame.image, _from_scratch(addon, bpy))

    cube.modifiers.new("more", "SUBSURF").levels = 1
    bpy.context.evaluated_depsgraph_get()
    assert reports[-1].rebuilt and whole_reads  # new counts: read whole
    frame = _frame(addon, bpy, session)
    assert frame.counts["triangles_uploaded"] == session.cache.scene_data.geometry.triangle_count
    np.testing.assert_array_equal(frame.image, _from_scratch(addon, bpy))


@pytest.mark.parametrize("change", ["add", "delete", "relink"])
def test_adding_deleting_and_relinking_objects_show_in_the_next_frame(addon, fed_session, change):
    import bpy

    session, reports = fed_session
    scene, cube = _scene(bpy)
    before = _frame(addon, bpy, session).image
    if change == "add":
        bpy.ops.mesh.primitive_cone_add(location=(0.2, -1.0, 0.6))
    elif change == "delete":
        bpy.data.objects.remove(cube)
    else:
        cube.data = bpy.data.meshes.new_from_object(bpy.data.objects["Sphere"])
    bpy.context.evaluated_depsgraph_get()
    assert reports[-1].rebuilt or reports[-1].extracted
    after = _frame(addon, bpy, session).image
    assert np.abs(after - before).max() > 1e-3
    np.testing.assert_array_equal(after, _from_scratch(addon, bpy))


def _f12(addon, bpy):
    bpy.ops.render.render()
    return addon.blender_adapter.engine.last_frame.image


def _small_render(bpy, scene):
    scene.render.engine = "HYBRID_RT"
    scene.render.resolution_x, scene.render.resolution_y = WIDTH, HEIGHT
    scene.render.resolution_percentage = 100
    scene.hybrid_rt.render_samples = 1
    camera = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    scene.collection.objects.link(camera)
    camera.matrix_world = [list(r) for r in look_at((5.0, -6.0, 4.0), (0.0, 0.0, 0.5))]
    scene.camera = camera


def test_a_second_f12_with_persistent_data_re_reads_only_what_changed(addon):
    import bpy

    scene, cube = _scene(bpy)
    _small_render(bpy, scene)
    engine = addon.blender_adapter.engine
    scene.render.use_persistent_data = True
    _f12(addon, bpy)
    assert set(engine.last_final_sync.extracted) == {"Plane", "Sphere", "Cube"}
    _f12(addon, bpy)
    assert engine.last_final_sync.extracted == [] and engine.last_final_sync.transformed == []
    cube.location.z += 0.5
    moved = _f12(addon, bpy)
    assert engine.last_final_sync.extracted == [] and engine.last_final_sync.transformed == ["Cube"]
    scene.render.use_persistent_data = False
    np.testing.assert_array_equal(moved, _f12(addon, bpy))  # a render that reads everything
    assert set(engine.last_final_sync.extracted) == {"Plane", "Sphere", "Cube"}


def test_a_tracked_scene_follows_frame_changes_and_equals_a_read_from_scratch(addon):
    """A timing report's frames: each re-reads only the animated object, and its arrays are
    bit for bit those of a one-off read of the same frame."""
    import bpy

    scene, cube = _scene(bpy)
    cube.keyframe_insert("location", frame=1)
    cube.location = (0.2, -0.5, 1.2)
    cube.keyframe_insert("location", frame=5)
    adapter = addon.blender_adapter
    tracked = adapter.scene_cache.TrackedScene()
    try:
        tracked.listen()
        for frame in (1, 2, 3):
            scene.frame_set(frame)
            depsgraph = bpy.context.evaluated_depsgraph_get()
            geometry = tracked.scene_data(depsgraph).geometry
            if frame > 1:
                assert tracked.last_sync.transformed == ["Cube"] and tracked.last_sync.extracted == []
            fresh = adapter.scene_cache.extract_scene(depsgraph).geometry
            for name in ("triangles", "normals", "material_ids", "object_ranges", "object_bounds"):
                np.testing.assert_array_equal(getattr(geometry, name), getattr(fresh, name), err_msg=name)
    finally:
        tracked.close()
    assert tracked._on_update not in bpy.app.handlers.frame_change_post


def test_the_viewport_sees_curves_text_and_metaballs_as_f12_does_and_follows_their_moves(addon, fed_session):
    import bpy

    session, reports = fed_session
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.curve.primitive_bezier_circle_add()
    bpy.context.object.data.extrude = 0.2
    bpy.ops.object.text_add(location=(5, 0, 0))
    text = bpy.context.object
    bpy.ops.object.metaball_add(location=(-5, 0, 0))
    bpy.context.evaluated_depsgraph_get()
    geometry = session.cache.scene_data.geometry
    fresh = addon.blender_adapter.scene_cache.extract_scene(bpy.context.evaluated_depsgraph_get()).geometry
    assert geometry.object_names == fresh.object_names and len(geometry.object_names) == 3, geometry.object_names
    np.testing.assert_array_equal(geometry.triangles, fresh.triangles)
    index = [i for i, name in enumerate(geometry.object_names) if name.endswith("Text")][0]
    before = geometry.object_bounds[index].copy()
    text.location.y += 2.0
    bpy.context.evaluated_depsgraph_get()
    after = session.cache.scene_data.geometry.object_bounds[index]
    np.testing.assert_allclose(after[:, 1] - before[:, 1], 2.0, atol=1e-5)


def test_a_moving_camera_skips_the_walk_and_a_view_layer_hide_does_not(addon, fed_session):
    """Moving the scene camera or changing its lens touches nothing the exported scene holds:
    the sync visits no instance. Hiding an object in the view layer arrives as a bare Scene
    update: the walk runs and the object is gone."""
    import bpy

    session, reports = fed_session
    scene, cube = _scene(bpy)
    _small_render(bpy, scene)
    bpy.context.evaluated_depsgraph_get()
    scene_data = session.cache.scene_data
    scene.camera.location.x += 1.0
    bpy.context.evaluated_depsgraph_get()
    scene.camera.data.lens = 30.0
    bpy.context.evaluated_depsgraph_get()
    assert reports[-2:] and all(not r.walked and not r.changed for r in reports[-2:])
    assert session.cache.scene_data is scene_data
    cube.hide_set(True)
    bpy.context.evaluated_depsgraph_get()
    assert reports[-1].walked and reports[-1].removed == 1
    assert "Cube" not in session.cache.scene_data.geometry.object_names


def test_a_thousand_linked_duplicates_share_one_mesh_upload(addon, fed_session):
    import bpy

    session, reports = fed_session
    scene, cube = _scene(bpy)
    for k in range(1000):
        duplicate = bpy.data.objects.new(f"dup{k}", cube.data)  # linked: one mesh datablock
        duplicate.location = (k % 40 * 0.3 - 6, k // 40 * 0.3 - 4, 2.0)
        duplicate.scale = (0.1, 0.1, 0.1)
        scene.collection.objects.link(duplicate)
    bpy.context.evaluated_depsgraph_get()
    frame = _frame(addon, bpy, session)
    instances = session.cache.scene_data.geometry.instances
    assert len(instances) == 1003 and len(instances.meshes) == 3  # plane, sphere, the cube's mesh
    assert frame.counts["meshes_uploaded"] == 3 and frame.counts["instances_written"] == 1003
    bpy.data.objects["dup500"].location.z += 1.0
    bpy.context.evaluated_depsgraph_get()
    assert reports[-1].transformed == ["dup500"] and not reports[-1].walked
    frame = _frame(addon, bpy, session)
    assert (frame.counts["meshes_uploaded"], frame.counts["instances_written"]) == (0, 1)


@pytest.mark.parametrize("link", ["DATA", "OBJECT"])
def test_assigning_another_material_to_a_slot_shows_in_the_next_frame(addon, fed_session, link):
    import bpy

    session, reports = fed_session
    scene, cube = _scene(bpy)
    red = bpy.data.materials.new("red")
    red.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (1.0, 0.0, 0.0, 1.0)
    cube.data.materials.append(bpy.data.materials.new("grey"))
    bpy.context.evaluated_depsgraph_get()
    before = _frame(addon, bpy, session).image
    cube.material_slots[0].link = link
    cube.material_slots[0].material = red
    bpy.context.evaluated_depsgraph_get()
    after = _frame(addon, bpy, session).image
    assert np.abs(after - before).max() > 0.05
    np.testing.assert_array_equal(after, _from_scratch(addon, bpy))


def test_editing_a_lamps_light_linking_shows_in_the_next_frame(addon, fed_session):
    import bpy

    session, reports = fed_session
    scene, cube = _scene(bpy)
    sun = next(obj for obj in scene.objects if obj.type == "LIGHT")
    receivers = bpy.data.collections.new("receivers")
    receivers.objects.link(cube)
    bpy.context.evaluated_depsgraph_get()
    before = _frame(addon, bpy, session).image
    sun.light_linking.receiver_collection = receivers  # the sun lights the cube alone: only the sun changed
    bpy.context.evaluated_depsgraph_get()
    linked = _frame(addon, bpy, session).image
    assert np.abs(linked - before).max() > 0.05
    np.testing.assert_array_equal(linked, _from_scratch(addon, bpy))
    receivers.collection_objects[0].light_linking.link_state = "EXCLUDE"  # all but the cube
    bpy.context.evaluated_depsgraph_get()
    excluded = _frame(addon, bpy, session).image
    assert np.abs(excluded - linked).max() > 0.05
    np.testing.assert_array_equal(excluded, _from_scratch(addon, bpy))


def test_editing_an_emissive_objects_light_linking_shows_in_the_next_frame(addon, fed_session):
    import bpy

    session, reports = fed_session
    scene, cube = _scene(bpy)
    glow = bpy.data.materials.new("glow")
    glow.node_tree.nodes["Principled BSDF"].inputs["Emission Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    glow.node_tree.nodes["Principled BSDF"].inputs["Emission Strength"].default_value = 20.0
    cube.data.materials.append(glow)
    bpy.context.evaluated_depsgraph_get()
    before = _frame(addon, bpy, session).image
    # The cube's light reaches the sphere alone (hybrid_engine/passes/emitters/emitter_links.py):
    # the floor around it loses its glow.
    receivers = bpy.data.collections.new("receivers")
    receivers.objects.link(bpy.data.objects["Sphere"])
    cube.light_linking.receiver_collection = receivers
    bpy.context.evaluated_depsgraph_get()
    linked = _frame(addon, bpy, session).image
    assert np.abs(linked - before).max() > 0.05
    np.testing.assert_array_equal(linked, _from_scratch(addon, bpy))


def test_a_linked_objects_material_edit_shows_in_the_next_frame(addon, fed_session):
    import bpy

    session, reports = fed_session
    scene, cube = _scene(bpy)
    grey = bpy.data.materials.new("grey")
    cube.data.materials.append(grey)
    receivers = bpy.data.collections.new("receivers")
    receivers.objects.link(cube)
    next(obj for obj in scene.objects if obj.type == "LIGHT").light_linking.receiver_collection = receivers
    bpy.context.evaluated_depsgraph_get()
    before = _frame(addon, bpy, session).image
    # The cube wears a copy of its material that carries its light set: an edit reaches it.
    grey.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (1.0, 0.0, 0.0, 1.0)
    bpy.context.evaluated_depsgraph_get()
    after = _frame(addon, bpy, session).image
    assert np.abs(after - before).max() > 0.05
    np.testing.assert_array_equal(after, _from_scratch(addon, bpy))
