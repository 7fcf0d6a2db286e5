# SPDX-License-Identifier: GPL-3.0-or-later
"""Render and Material Properties panels for the ``HYBRID_RT`` engine.

Blender shows a panel for an engine when the panel's ``COMPAT_ENGINES`` names it (or the
panel polls for it). Our own panels poll for ``context.engine == 'HYBRID_RT'``; Blender's
standard panels that make sense for this engine (output format, colour management, camera,
light, world and material surface...) get ``'HYBRID_RT'`` added to their ``COMPAT_ENGINES``
on register and removed again on unregister, the way Blender's bundled engines do it.
"""
from __future__ import annotations

import bpy

from ..blender_adapter.extract import material_params
from ..operators import near_cube_overlay
from .light_panel import DATA_PT_hybrid_rt_light

ENGINE_ID = "HYBRID_RT"
_EEVEE_IDS = frozenset({"BLENDER_EEVEE", "BLENDER_EEVEE_NEXT"})

# EEVEE-only panels that show settings this engine also reads.
_EEVEE_PANELS_KEPT = frozenset({
    "EEVEE_MATERIAL_PT_context_material",
    "EEVEE_MATERIAL_PT_surface",
    "EEVEE_WORLD_PT_surface",
})
# Panels for features this engine does not have (depth of field, light probes, Freestyle,
# per-light influence, shadow terminator...), EEVEE's light panels (ui/light_panel.py draws
# the lamp controls this engine renders, and only those), and Blender's render-pass panels, which list
# passes this engine does not write (its own Passes panel below lists those it does).
_PANELS_SKIPPED_PREFIXES = (
    "DATA_PT_camera_dof",
    "DATA_PT_lightprobe",
    "DATA_PT_context_lightprobe",
    "VIEWLAYER_PT_layer_passes",
    "VIEWLAYER_PT_filter",
    "VIEWLAYER_PT_freestyle",
    "RENDER_PT_freestyle",
    "MATERIAL_PT_freestyle",
    "OBJECT_PT_shadow_terminator",
    "VIEW3D_PT_shading_render_pass",
    "SCENE_PT_eevee",
)


def _is_compatible(panel) -> bool:
    """Whether a Blender panel that EEVEE uses should also show for this engine."""
    name = panel.__name__
    if name in _EEVEE_PANELS_KEPT:
        return True
    if "eevee" in name.lower() or name.startswith(_PANELS_SKIPPED_PREFIXES):
        return False
    return True


def compatible_panels() -> list[type]:
    """Blender's own panels that get ``HYBRID_RT`` added to their COMPAT_ENGINES."""
    panels = []
    for panel in bpy.types.Panel.__subclasses__():
        engines = getattr(panel, "COMPAT_ENGINES", None)
        if isinstance(engines, set) and engines & _EEVEE_IDS and _is_compatible(panel):
            panels.append(panel)
    return panels


# Panels whose COMPAT_ENGINES we changed (so unregister removes exactly those additions).
_patched_panels: list[type] = []


class HybridRTPanel:
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    COMPAT_ENGINES = {ENGINE_ID}

    @classmethod
    def poll(cls, context) -> bool:
        return context.engine == ENGINE_ID


class RENDER_PT_hybrid_rt(HybridRTPanel, bpy.types.Panel):
    """Render mode and recursion."""

    bl_label = "Hybrid RT"
    bl_context = "render"

    def draw(self, context) -> None:
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        settings = context.scene.hybrid_rt
        col = layout.column()
        col.prop(settings, "mode")
        col.prop(settings, "render_samples")
        col.prop(settings, "max_depth")
        col.prop(settings, "near_size")
        col.operator("hybrid_rt.show_near_cube", icon="CUBE", depress=near_cube_overlay.is_enabled())
        # Per-pass frame times of the scene's frame range (JSON, CSV and a chart).
        layout.operator("hybrid_rt.timing_report", icon="TIME")


class RENDER_PT_hybrid_rt_cube_map(HybridRTPanel, bpy.types.Panel):
    """The G-buffer cube map and its ray marching (paper §3.2, §3.4)."""

    bl_label = "Cube Map"
    bl_context = "render"
    bl_parent_id = "RENDER_PT_hybrid_rt"

    def draw(self, context) -> None:
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        settings = context.scene.hybrid_rt
        layout.active = settings.mode in ("HYBRID", "PROVENANCE")
        col = layout.column()
        col.prop(settings, "cube_resolution")
        col.prop(settings, "cube_far")
        layout.prop(settings, "cube_back_layer")
        layout.prop(settings, "cube_hidden_exit")
        layout.prop(settings, "cube_march")
        col = layout.column(align=True)
        col.active = settings.cube_march == "SAMPLED"
        col.prop(settings, "n_min", text="Ray March Samples Min")
        col.prop(settings, "n_max", text="Max")


class RENDER_PT_hybrid_rt_shadows(HybridRTPanel, bpy.types.Panel):
    """Shadow maps of the deferred shading (paper §3.5)."""

    bl_label = "Shadows"
    bl_context = "render"
    bl_parent_id = "RENDER_PT_hybrid_rt"

    def draw(self, context) -> None:
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        settings = context.scene.hybrid_rt
        col = layout.column()
        col.prop(settings, "shadow_resolution")
        col.prop(settings, "shadow_bias")


class RENDER_PT_hybrid_rt_viewport(HybridRTPanel, bpy.types.Panel):
    """Viewport-only settings."""

    bl_label = "Viewport"
    bl_context = "render"
    bl_parent_id = "RENDER_PT_hybrid_rt"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context) -> None:
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        layout.column().prop(context.scene.hybrid_rt, "viewport_scale")


class RENDER_PT_hybrid_rt_film(HybridRTPanel, bpy.types.Panel):
    """Film: a transparent background for compositing (hybrid_engine/film.py)."""

    bl_label = "Film"
    bl_context = "render"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context) -> None:
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        layout.column().prop(context.scene.render, "film_transparent", text="Transparent")


class VIEWLAYER_PT_hybrid_rt_passes(HybridRTPanel, bpy.types.Panel):
    """The data passes this engine writes besides Combined (hybrid_engine/film.py)."""

    bl_label = "Passes"
    bl_context = "view_layer"

    def draw(self, context) -> None:
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        view_layer = context.view_layer
        col = layout.column(heading="Data", align=True)
        col.prop(view_layer, "use_pass_combined")
        col.prop(view_layer, "use_pass_z")
        col.prop(view_layer, "use_pass_normal")


class MATERIAL_PT_hybrid_rt(HybridRTPanel, bpy.types.Panel):
    """The paper's per-material thickness and what the engine makes of the surface shader."""

    bl_label = "Hybrid RT"
    bl_context = "material"

    @classmethod
    def poll(cls, context) -> bool:
        return context.engine == ENGINE_ID and context.material is not None

    def draw(self, context) -> None:
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        material = context.material
        layout.column().prop(material.hybrid_rt, "thickness")

        # The values the renderer uses, derived with the extractor's own mapping (read-only).
        params = material_params(material)
        col = layout.column(align=True)
        col.label(text="Derived from the surface shader:")
        grid = col.grid_flow(columns=2, even_columns=True, align=True)
        grid.label(text="Reflectivity")
        grid.label(text=f"{params['reflectivity']:.3f}")
        grid.label(text="Transmission")
        grid.label(text=f"{params['transmission']:.3f}")
        grid.label(text="IOR")
        grid.label(text=f"{params['ior']:.3f}")


_CLASSES = (
    RENDER_PT_hybrid_rt,
    RENDER_PT_hybrid_rt_cube_map,
    RENDER_PT_hybrid_rt_shadows,
    RENDER_PT_hybrid_rt_viewport,
    RENDER_PT_hybrid_rt_film,
    VIEWLAYER_PT_hybrid_rt_passes,
    MATERIAL_PT_hybrid_rt,
    DATA_PT_hybrid_rt_light,
)


def register() -> None:
    for cls in _CLASSES:
        bpy.utils.register_class(cls)
    for panel in compatible_panels():
        if ENGINE_ID not in panel.COMPAT_ENGINES:
            panel.COMPAT_ENGINES.add(ENGINE_ID)
            _patched_panels.append(panel)


def unregister() -> None:
    while _patched_panels:
        _patched_panels.pop().COMPAT_ENGINES.discard(ENGINE_ID)
    for cls in reversed(_CLASSES):
        if cls.is_registered:
            bpy.utils.unregister_class(cls)
