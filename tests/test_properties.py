# SPDX-License-Identifier: GPL-3.0-or-later
"""Blender properties and panels: generated from the core's tables, stored in the .blend,
and removed without a trace on unregister."""
from __future__ import annotations

from dataclasses import asdict, fields

import bpy
import pytest

from hybrid_engine.scene.settings import CUBE_MARCHES, FIELD_LIMITS, MODES, WORLD_LIGHTS, RenderSettings

FLOAT32_TOLERANCE = 1e-6  # Blender stores float properties as float32


def _rna(struct_type, name):
    return struct_type.bl_rna.properties[name]


def test_every_render_setting_is_stored_with_its_type_and_clamped_to_the_cores_limits(addon):
    """What the artist can type reaches the core: each field is a scene property of the
    matching kind, a value past either limit is clamped by Blender to the limit the core
    validates (so the core never sees it), and the default is one the core accepts."""
    group = type(bpy.context.scene.hybrid_rt)
    stored = bpy.context.scene.hybrid_rt
    defaults = RenderSettings()
    kinds = {bool: "BOOLEAN", int: "INT", float: "FLOAT", str: "ENUM"}
    for f in fields(RenderSettings):
        prop = _rna(group, f.name)
        default = getattr(defaults, f.name)
        assert prop.type == kinds[type(default)], f.name
        assert prop.description and f.name not in prop.description, f.name  # words, not the identifier
        if f.name not in FIELD_LIMITS:
            continue
        lo, hi = FIELD_LIMITS[f.name]
        kind = type(default)
        for beyond, limit in ((lo - 1, lo), (hi + 1, hi)):
            setattr(stored, f.name, kind(beyond))
            assert getattr(stored, f.name) == pytest.approx(limit, rel=FLOAT32_TOLERANCE), f.name
    for f in fields(RenderSettings):  # back to the defaults (limits pushed their partners)
        setattr(stored, f.name, getattr(defaults, f.name))
    assert asdict(addon.blender_adapter.properties.settings_from_scene(bpy.context.scene)) == asdict(defaults)
    assert [item.identifier for item in _rna(group, "mode").enum_items] == list(MODES)
    assert [item.identifier for item in _rna(group, "cube_march").enum_items] == list(CUBE_MARCHES)
    assert [item.identifier for item in _rna(group, "world_light").enum_items] == list(WORLD_LIGHTS)


def test_settings_from_scene_returns_the_stored_values(addon):
    settings_from_scene = addon.blender_adapter.properties.settings_from_scene
    scene = bpy.context.scene
    assert settings_from_scene(scene) == type(settings_from_scene(scene))()  # defaults
    stored = scene.hybrid_rt
    stored.mode, stored.near_size, stored.max_depth = "FULL_BVH", 2.5, 7
    stored.cube_resolution, stored.n_min, stored.n_max = 256, 8, 32
    stored.cube_back_layer = True
    got = settings_from_scene(scene)
    assert (got.mode, got.near_size, got.max_depth) == ("FULL_BVH", 2.5, 7)
    assert (got.cube_resolution, got.n_min, got.n_max) == (256, 8, 32)
    assert got.cube_back_layer is True


def test_raising_n_min_above_n_max_pushes_n_max_and_back(addon):
    stored = bpy.context.scene.hybrid_rt
    stored.n_max = 40
    stored.n_min = 100
    assert stored.n_max == 100
    stored.n_max = 10
    assert stored.n_min == 10


def test_material_thickness_is_a_factor_from_zero_to_one_defaulting_to_a_half(addon):
    prop = _rna(type(bpy.data.materials.new("m").hybrid_rt), "thickness")
    assert (prop.hard_min, prop.hard_max, prop.default, prop.subtype) == (0.0, 1.0, 0.5, "FACTOR")
    assert "thin" in prop.description and "far plane" in prop.description


def test_properties_survive_saving_and_reloading_the_blend(addon, tmp_path):
    scene = bpy.context.scene
    scene.hybrid_rt.mode = "PROVENANCE"
    scene.hybrid_rt.near_size = 3.25
    scene.hybrid_rt.cube_resolution = 128
    material = bpy.data.materials.new("Thick")
    material.use_fake_user = True
    material.hybrid_rt.thickness = 0.875
    scene.view_layers[0].hybrid_rt.denoising_store_passes = True
    path = tmp_path / "settings.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    assert bpy.context.scene.hybrid_rt.mode == "HYBRID"  # really a fresh session
    bpy.ops.wm.open_mainfile(filepath=str(path))
    scene = bpy.context.scene
    assert scene.hybrid_rt.mode == "PROVENANCE"
    assert scene.hybrid_rt.near_size == pytest.approx(3.25)
    assert scene.hybrid_rt.cube_resolution == 128
    assert bpy.data.materials["Thick"].hybrid_rt.thickness == pytest.approx(0.875)
    assert scene.view_layers[0].hybrid_rt.denoising_store_passes


def test_a_blend_saved_with_the_retired_world_light_rays_switch_loads_with_traced_diffuse_light(addon, tmp_path):
    """Files saved before World Light became a choice hold a ``sky_rays`` value the add-on no
    longer registers: they open, and render with the traced diffuse light (the default)."""
    scene = bpy.context.scene
    scene.hybrid_rt["sky_rays"] = True  # as an older add-on stored it
    scene.hybrid_rt.diffuse_bounces = 2
    path = tmp_path / "old.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.open_mainfile(filepath=str(path))
    settings = addon.blender_adapter.properties.settings_from_scene(bpy.context.scene)
    assert (settings.world_light, settings.diffuse_bounces, settings.traces_diffuse) == ("RAYS", 2, True)


def test_repeated_register_unregister_leaves_nothing_behind(addon):
    panels = addon.ui.panels
    patched = panels.compatible_panels()
    assert patched, "no standard panel was made compatible"
    for _ in range(3):
        addon.unregister()
        assert not hasattr(bpy.types.Scene, "hybrid_rt")
        assert not hasattr(bpy.types.Material, "hybrid_rt")
        assert not hasattr(bpy.types.ViewLayer, "hybrid_rt")
        assert not addon.blender_adapter.properties.HybridRTSceneSettings.is_registered
        assert not addon.blender_adapter.properties.HybridRTMaterialSettings.is_registered
        assert not panels.RENDER_PT_hybrid_rt_sampling.is_registered
        assert not any("HYBRID_RT" in p.COMPAT_ENGINES for p in patched)
        addon.register()
        assert hasattr(bpy.types.Scene, "hybrid_rt")
        assert all("HYBRID_RT" in p.COMPAT_ENGINES for p in patched)


def test_standard_panels_that_apply_are_enabled_and_eevee_specific_ones_are_not(addon):
    for name in ("RENDER_PT_format", "RENDER_PT_output", "RENDER_PT_color_management",
                 "EEVEE_MATERIAL_PT_surface", "EEVEE_WORLD_PT_surface",
                 "DATA_PT_camera", "DATA_PT_lens"):
        assert "HYBRID_RT" in getattr(bpy.types, name).COMPAT_ENGINES, name
    for name in ("MATERIAL_PT_preview", "DATA_PT_preview", "TEXTURE_PT_preview"):  # the engine renders previews
        assert "HYBRID_RT" in getattr(bpy.types, name).COMPAT_ENGINES, name
    assert addon.blender_adapter.engine.HybridRTRenderEngine.bl_use_preview
    for name in ("RENDER_PT_eevee_sampling", "DATA_PT_camera_dof", "RENDER_PT_stereoscopy", "VIEWLAYER_PT_layer_passes",
                 "DATA_PT_lightprobe_bake", "EEVEE_MATERIAL_PT_settings", "DATA_PT_EEVEE_light",
                 "DATA_PT_EEVEE_light_shadow", "DATA_PT_EEVEE_light_distance"):
        assert "HYBRID_RT" not in getattr(bpy.types, name).COMPAT_ENGINES, name


def test_own_panels_show_only_for_this_engine(addon):
    panels = addon.ui.panels

    class FakeContext:
        engine = "BLENDER_EEVEE"
        material = bpy.data.materials.new("m")

    own = RENDER_PANELS(panels) + (panels.MATERIAL_PT_hybrid_rt, panels.VIEWLAYER_PT_hybrid_rt_passes)
    assert not any(panel.poll(FakeContext) for panel in own)
    FakeContext.engine = "HYBRID_RT"
    assert all(panel.poll(FakeContext) for panel in own)


class RecordingLayout:
    """Stands in for a panel's UILayout: records (data, property) pairs and checks that each
    property exists, as Blender would when drawing (a misspelt name draws an error there)."""

    def __init__(self, drawn: list) -> None:
        self.drawn = drawn
        self.use_property_split = self.use_property_decorate = self.active = False

    def column(self, **_kwargs):
        return self

    def row(self, **_kwargs):
        return self

    def prop(self, data, name, **_kwargs):
        assert name in data.bl_rna.properties, f"{type(data).__name__} has no property {name!r}"
        self.drawn.append(name)

    def operator(self, idname, **_kwargs):
        self.drawn.append(idname)

    def prop_enum(self, data, name, value, **_kwargs):
        assert value in [item.identifier for item in data.bl_rna.properties[name].enum_items], value
        self.drawn.append(f"{name}={value}")

    def label(self, **_kwargs):
        pass

    def grid_flow(self, **_kwargs):
        return self


def RENDER_PANELS(panels) -> tuple:
    return (panels.RENDER_PT_hybrid_rt_sampling, panels.RENDER_PT_hybrid_rt_light_paths,
            panels.RENDER_PT_hybrid_rt_hybrid, panels.RENDER_PT_hybrid_rt_shadows,
            panels.RENDER_PT_hybrid_rt_film, panels.RENDER_PT_hybrid_rt_performance,
            panels.RENDER_PT_hybrid_rt_diagnostics)


def _draw(panel, drawn: list, **context) -> float:
    """Draw ``panel`` with a recording layout; returns the milliseconds of the drawing thread's
    CPU time it took (a draw's cost, not the time other processes held the cores)."""
    import time

    FakeContext = type("FakeContext", (), {"scene": bpy.context.scene, "view_layer": bpy.context.view_layer,
                                          "engine": "HYBRID_RT", **context})

    class FakePanel:
        layout = RecordingLayout(drawn)

    start = time.thread_time()
    panel.draw(FakePanel(), FakeContext)
    return (time.thread_time() - start) * 1e3


def test_the_render_panels_draw_every_setting_once_the_report_and_the_overlay_quickly(addon):
    """Sampling, Light Paths, Hybrid (Shadows inside), Film and Diagnostics, as Cycles users
    expect: together they show every setting once, the timing report and the near-cube
    overlay, each within 5 ms."""
    drawn: list[str] = []
    stored = bpy.context.scene.hybrid_rt
    automatic = ("near_size", "cube_far", "cube_resolution", "near_min", "near_max")
    for near_cube_mode in ("FIXED", "BUDGET"):  # the near cube's fields follow its mode
        for on in (True, False):  # an Automatic setting shows its value only when fixed
            stored.near_cube_mode = near_cube_mode
            for name in automatic:
                setattr(stored, f"{name}_auto", on)
            for panel in RENDER_PANELS(addon.ui.panels):
                assert _draw(panel, drawn) < 5.0, panel.__name__
    stored.near_cube_mode = "FIXED"
    for name in automatic:
        setattr(stored, f"{name}_auto", True)
    assert {f"{name}_auto" for name in automatic} <= set(drawn)
    drawn = list(dict.fromkeys(drawn))
    settings = [f.name for f in fields(RenderSettings)]
    assert sorted(name for name in drawn if name in settings) == sorted(settings)
    assert {"hybrid_rt.timing_report", "show_near_cube", "film_transparent", "filter_size",
            "mode=PROVENANCE", "frame_budget_fps", "use_persistent_data"} <= set(drawn)
    assert addon.ui.panels.RENDER_PT_hybrid_rt_shadows.bl_parent_id == "RENDER_PT_hybrid_rt_hybrid"


def test_the_material_panel_draws_without_reading_image_pixels(addon, monkeypatch):
    material = bpy.data.materials.new("textured")
    image = bpy.data.images.new("big", 2048, 2048)
    texture = material.node_tree.nodes.new("ShaderNodeTexImage")
    texture.image = image
    material.node_tree.links.new(texture.outputs["Color"],
                                 material.node_tree.nodes["Principled BSDF"].inputs["Base Color"])

    def no_pixels(_image):
        raise AssertionError("the material panel read an image's pixels")

    monkeypatch.setattr(addon.blender_adapter.export.materials, "image_pixels", no_pixels)
    drawn: list[str] = []
    assert _draw(addon.ui.panels.MATERIAL_PT_hybrid_rt, drawn, material=material) < 5.0
    assert drawn == ["thickness"]


def test_sliders_have_soft_limits_inside_the_hard_ones(addon):
    group = type(bpy.context.scene.hybrid_rt)
    soft = addon.blender_adapter.properties.SOFT_LIMITS
    for name, (lo, hi) in FIELD_LIMITS.items():
        prop = _rna(group, name)
        assert lo <= prop.soft_min < prop.soft_max <= hi, name
        assert (prop.soft_min, prop.soft_max) == pytest.approx(soft[name], rel=FLOAT32_TOLERANCE), name
        assert (prop.soft_min, prop.soft_max) != pytest.approx((lo, hi)), f"{name}: the slider spans the hard range"


def test_raising_the_near_size_past_the_far_clip_pushes_the_far_clip_and_back(addon):
    stored = bpy.context.scene.hybrid_rt
    stored.cube_far = 20.0
    stored.near_size = 50.0
    assert stored.cube_far > 50.0
    stored.cube_far = 10.0
    assert stored.near_size < 10.0
    addon.blender_adapter.properties.settings_from_scene(bpy.context.scene)  # consistent


def test_an_inconsistent_setting_from_a_script_is_named_by_its_label(addon):
    stored = bpy.context.scene.hybrid_rt
    stored["near_size"], stored["cube_far"] = 50.0, 10.0  # ID properties: no update callbacks
    with pytest.raises(ValueError, match="'Far Clip'.*'Near Size'"):
        addon.blender_adapter.properties.settings_from_scene(bpy.context.scene)


def test_film_and_passes_panels_draw_the_properties_the_final_render_reads(addon):
    panels = addon.ui.panels
    drawn: list[str] = []

    class FakeContext:
        scene = bpy.context.scene
        view_layer = bpy.context.view_layer

    class FakePanel:
        layout = RecordingLayout(drawn)

    for panel in (panels.RENDER_PT_hybrid_rt_film, panels.VIEWLAYER_PT_hybrid_rt_passes):
        panel.draw(FakePanel(), FakeContext)
    engine = addon.blender_adapter.engine
    assert "film_transparent" in drawn
    assert {flag.rpartition(".")[2] for flag, *_ in engine.DATA_PASSES.values()} <= set(drawn)
    # Only the passes the engine writes: Combined, the data passes, Vector, Cryptomatte and the light passes.
    written = {"use_pass_combined", "use_pass_vector", *(flag for flag, *_ in engine.DATA_PASSES.values()),
               *engine.CRYPTOMATTE_FLAGS.values(), *engine.LIGHT_PASSES}
    assert {name for name in drawn if name.startswith("use_pass_")} <= written
    assert set(engine.CRYPTOMATTE_FLAGS.values()) | {"pass_cryptomatte_depth"} <= set(drawn)


@pytest.mark.parametrize("kind", ["POINT", "SPOT", "SUN", "AREA"])
def test_light_panel_draws_the_lamp_controls_the_engine_renders_and_no_other(addon, kind):
    light = bpy.data.lights.new(f"panel_{kind}", kind)
    light.use_temperature = True
    drawn: list[str] = []

    class FakeContext:
        engine = "HYBRID_RT"

    FakeContext.light = light

    class FakePanel:
        layout = RecordingLayout(drawn)

    panel = addon.ui.light_panel.DATA_PT_hybrid_rt_light
    assert panel.poll(FakeContext)
    panel.draw(FakePanel(), FakeContext)
    supported = {"type", "color", "use_temperature", "temperature", "energy", "exposure", "normalize",
                 "shadow_soft_size", "spot_size", "spot_blend", "angle", "shape", "size", "size_y", "use_shadow"}
    assert set(drawn) <= supported
    assert {"exposure", "temperature", "normalize", "energy"} <= set(drawn)
    size = {"POINT": "shadow_soft_size", "SPOT": "shadow_soft_size", "SUN": "angle", "AREA": "size"}[kind]
    assert size in drawn
    # Controls Blender shows for EEVEE that change nothing here stay hidden.
    assert not {"use_soft_falloff", "spread", "shadow_jitter", "shadow_resolution_limit"} & set(drawn)


def test_raising_the_budgets_minimum_above_its_maximum_pushes_the_maximum_and_back(addon):
    stored = bpy.context.scene.hybrid_rt
    stored.near_max = 3.0
    stored.near_min = 8.0
    assert stored.near_max == pytest.approx(8.0)
    stored.near_max = 1.0
    assert stored.near_min == pytest.approx(1.0)


def test_the_frame_budget_reads_and_sets_as_a_frame_rate(addon):
    stored = bpy.context.scene.hybrid_rt
    stored.frame_budget_fps = 60.0
    assert stored.frame_budget_ms == pytest.approx(1000.0 / 60.0)
    stored.frame_budget_ms = 40.0
    assert stored.frame_budget_fps == pytest.approx(25.0)
    assert addon.blender_adapter.properties.settings_from_scene(bpy.context.scene).frame_budget_ms == pytest.approx(40.0)
    stored.frame_budget_fps = 1.0e6  # past the fastest budget: clamped to its limit
    assert stored.frame_budget_ms == pytest.approx(FIELD_LIMITS["frame_budget_ms"][0])
    stored.frame_budget_ms = RenderSettings().frame_budget_ms


def test_the_material_preview_panel_shows_the_thickness_for_this_engine_only(addon):
    """The paper's per-material thickness is drawn under the material's preview, which renders
    it; another engine's preview panel stays as Blender draws it."""
    panels = addon.ui.panels
    material = bpy.data.materials.new("m")
    assert panels.draw_preview_thickness in bpy.types.MATERIAL_PT_preview._dyn_ui_initialize()
    drawn: list = []
    _draw(type("Preview", (), {"draw": panels.draw_preview_thickness}), drawn, material=material)
    assert drawn == ["thickness"]
    drawn.clear()
    _draw(type("Preview", (), {"draw": panels.draw_preview_thickness}), drawn, material=material,
          engine="BLENDER_EEVEE")
    assert drawn == []
    addon.unregister()
    try:
        assert panels.draw_preview_thickness not in bpy.types.MATERIAL_PT_preview._dyn_ui_initialize()
    finally:
        addon.register()
