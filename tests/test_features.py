# SPDX-License-Identifier: GPL-3.0-or-later
"""The feature table (blender_adapter/features.py): the README shows exactly it, and each
feature the engine does not render is named to the artist once per render when a scene uses
it, through Blender's report."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from test_engine import build_plane_scene

README = Path(__file__).resolve().parent.parent / "README.md"


def test_the_readme_shows_the_feature_table_of_the_code(addon):
    table = addon.blender_adapter.features.feature_table()
    text = README.read_text(encoding="utf-8")
    assert table in text, "README.md's feature table differs from blender_adapter/features.py:feature_table()"


def test_every_feature_with_a_message_can_find_itself_and_every_unsupported_one_has_a_message(addon):
    features = addon.blender_adapter.features
    for feature in features.FEATURES:
        assert feature.status in (features.SUPPORTED, features.APPROXIMATED, features.UNSUPPORTED)
        assert (feature.message is None) == (feature.used is None), feature.name
        if feature.status == features.UNSUPPORTED and feature.name != "Panoramic cameras":  # an error instead
            assert feature.message is not None, f"{feature.name} is dropped without a word"


def _switch_on(bpy, scene, name: str) -> None:
    """Turn on the feature ``name`` in the plane scene of test_engine."""
    plane = next(obj for obj in scene.objects if obj.type == "MESH")
    if name == "Stereoscopy":
        scene.render.use_multiview = True
    elif name == "Freestyle":
        scene.render.use_freestyle = True
    elif name == "Ray Visibility":
        plane.visible_camera = False
    elif name == "Holdout":
        plane.is_holdout = True
    elif name == "Shadow Catcher":
        plane.is_shadow_catcher = True
    elif name == "Light Linking of emissive objects":
        plane.light_linking.receiver_collection = bpy.data.collections.new("receivers")
    elif name == "World Volume":
        tree = scene.world.node_tree
        volume = tree.nodes.new("ShaderNodeVolumePrincipled")
        tree.links.new(volume.outputs[0], tree.get_output_node("ALL").inputs["Volume"])
    elif name in ("Hair Curves", "Volume objects", "Point Clouds", "Grease Pencil"):
        kind = {"Hair Curves": "hair_curves", "Volume objects": "volumes", "Point Clouds": "pointclouds",
                "Grease Pencil": "grease_pencils"}[name]
        data = getattr(bpy.data, kind).new(name)
        scene.collection.objects.link(bpy.data.objects.new(name, data))
    else:
        raise AssertionError(f"no way to switch on {name!r} in this test: add one")


MESSAGED = ["Stereoscopy", "Freestyle", "Ray Visibility", "Holdout",
            "Shadow Catcher", "Light Linking of emissive objects", "World Volume", "Hair Curves",
            "Volume objects", "Point Clouds",
            "Grease Pencil"]


def test_the_test_switches_on_every_feature_that_has_a_message(addon):
    assert sorted(MESSAGED) == sorted(f.name for f in addon.blender_adapter.features.FEATURES if f.message)


@pytest.mark.parametrize("name", MESSAGED)
def test_a_render_that_uses_a_feature_reports_its_message_once(addon, capfd, name):
    import bpy

    feature = next(f for f in addon.blender_adapter.features.FEATURES if f.name == name)
    scene = build_plane_scene(bpy, "SUN", 1.0, size=8)
    scene.render.engine = "HYBRID_RT"
    scene.hybrid_rt.mode = "RASTER"
    pattern = re.escape(feature.message.split("{names}")[0].strip())
    capfd.readouterr()
    bpy.ops.render.render()
    assert not re.search(pattern, capfd.readouterr().out), f"{name} reported though unused"
    _switch_on(bpy, scene, name)
    bpy.ops.render.render()
    out = capfd.readouterr().out
    assert len(re.findall("Warning: Hybrid RT: " + pattern, out)) == 1, out


def test_the_viewport_reports_a_feature_when_it_comes_into_use_not_on_every_update(addon):
    import bpy

    scene = build_plane_scene(bpy, "SUN", 1.0, size=8)
    scene.render.engine = "HYBRID_RT"
    reported = []

    class FakeEngine:
        def report(self, levels, text):
            reported.append(text)

    viewport = addon.blender_adapter.viewport
    engine = FakeEngine()

    def updates(count: int) -> int:
        before = len([t for t in reported if "Stereoscopy" in t])
        for _ in range(count):
            viewport.view_update(engine, bpy.context, bpy.context.evaluated_depsgraph_get())
        return len([t for t in reported if "Stereoscopy" in t]) - before

    try:
        assert updates(2) == 0
        scene.render.use_multiview = True
        assert updates(3) == 1
        scene.render.use_multiview = False
        assert updates(1) == 0
        scene.render.use_multiview = True
        assert updates(2) == 1
    finally:
        viewport.release_all()
