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

from ..blender_adapter import effective_values
from ..blender_adapter.export.materials import material_params
from ..hybrid_engine.scene.scale import auto_cube_resolution
from ..hybrid_engine.scene.settings import DIAGNOSTIC_VIEWS
from .light_panel import DATA_PT_hybrid_rt_light

ENGINE_ID = "HYBRID_RT"
_EEVEE_IDS = frozenset({"BLENDER_EEVEE", "BLENDER_EEVEE_NEXT"})

# EEVEE-only panels that show settings this engine also reads.
_EEVEE_PANELS_KEPT = frozenset({
    "EEVEE_MATERIAL_PT_context_material",
    "EEVEE_MATERIAL_PT_surface",
    "EEVEE_WORLD_PT_surface",
    "EEVEE_WORLD_PT_mist",  # the World's mist settings, which the Mist pass follows
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
    # Stereoscopy: the engine renders one view per camera; multi-view output would repeat it.
    "RENDER_PT_stereoscopy",
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


def _split(layout):
    layout.use_property_split = True
    layout.use_property_decorate = False
    return layout


def _effective_text(context, name: str) -> str:
    """What an Automatic setting rendered the last frame with, or, before any frame, what
    can be told without the geometry (the face resolution of the render's size)."""
    last = effective_values.last()
    if name == "cube_resolution":
        if last is not None:
            return f"{last.cube_resolution} px"
        render = context.scene.render
        scale = render.resolution_percentage / 100.0
        res = auto_cube_resolution(context.scene.hybrid_rt.cube_resolution_ratio,
                                   round(render.resolution_x * scale), round(render.resolution_y * scale))
        return f"{res} px at the render size"
    if last is None:
        return "from the scene, at the next frame"
    return f"{getattr(last, name):.4g} m"


def _automatic(layout, context, name: str, label: str) -> None:
    """A setting that may follow the scene: its Automatic switch, then the value you set
    or, while Automatic, the value the last frame took."""
    settings = context.scene.hybrid_rt
    row = layout.row(heading=label)
    row.prop(settings, f"{name}_auto", text="")
    if getattr(settings, name) > 0:
        row.prop(settings, name, text="")
    else:
        row.label(text=_effective_text(context, name))


class RENDER_PT_hybrid_rt_sampling(HybridRTPanel, bpy.types.Panel):
    """Samples per pixel, as Cycles' Sampling panel: the viewport's while nothing changes,
    the final render's always."""

    bl_label = "Sampling"
    bl_context = "render"

    def draw(self, context) -> None:
        settings = context.scene.hybrid_rt
        col = _split(self.layout).column(align=True)
        col.prop(settings, "viewport_samples", text="Viewport")
        col.prop(settings, "render_samples", text="Render")
        col = _split(self.layout).column(heading="Denoise")
        col.prop(settings, "denoise_viewport")
        col.prop(settings, "denoise_render")


class RENDER_PT_hybrid_rt_light_paths(HybridRTPanel, bpy.types.Panel):
    """How far reflections and refractions are followed, and how the World's light is found."""

    bl_label = "Light Paths"
    bl_context = "render"

    def draw(self, context) -> None:
        settings = context.scene.hybrid_rt
        layout = _split(self.layout)
        layout.prop(settings, "mode")
        col = layout.column()
        col.prop(settings, "max_depth")
        layout.prop(settings, "world_light")
        # RASTER and PROVENANCE build no BVH to trace through: they take the screen space.
        rays = settings.world_light == "RAYS" and settings.mode not in ("RASTER", "PROVENANCE")
        col = layout.column(align=True)
        col.active = rays
        col.prop(settings, "diffuse_bounces", text="Bounces")
        col.prop(settings, "diffuse_rays", text="Rays")
        col.prop(settings, "radiance_cache")
        col.prop(settings, "bounce_feedback")
        col = layout.column()
        col.active = not rays
        col.prop(settings, "ao_distance")


class RENDER_PT_hybrid_rt_hybrid(HybridRTPanel, bpy.types.Panel):
    """The paper's two structures: the near cube, traced exactly, and the cube map beyond it
    (§3.2-3.4)."""

    bl_label = "Hybrid"
    bl_context = "render"

    def draw(self, context) -> None:
        settings = context.scene.hybrid_rt
        layout = _split(self.layout)
        layout.active = settings.mode in ("HYBRID", "PROVENANCE", *DIAGNOSTIC_VIEWS)
        layout.prop(settings, "near_cube_mode")
        if settings.near_cube_mode == "BUDGET":
            col = layout.column(align=True)
            col.prop(settings, "frame_budget_ms")
            col.prop(settings, "frame_budget_fps")
            _automatic(col, context, "near_min", "Min Size")
            _automatic(col, context, "near_max", "Max Size")
        else:
            _automatic(layout, context, "near_size", "Near Size")
        col = layout.column(heading="Cube Map")
        _automatic(col, context, "cube_resolution", "Face Resolution")
        sub = col.column()
        sub.active = settings.cube_resolution <= 0
        sub.prop(settings, "cube_resolution_ratio")
        _automatic(col, context, "cube_far", "Far Clip")
        col = layout.column()
        col.prop(settings, "cube_back_layer")
        col.prop(settings, "cube_hidden_exit")
        col.prop(settings, "lit_cube")
        col.prop(settings, "cube_march")
        sub = col.column(align=True)
        sub.active = settings.cube_march == "SAMPLED"
        sub.prop(settings, "n_min", text="Samples Min")
        sub.prop(settings, "n_max", text="Max")


class RENDER_PT_hybrid_rt_shadows(HybridRTPanel, bpy.types.Panel):
    """Shadow maps of the deferred shading (paper §3.5)."""

    bl_label = "Shadows"
    bl_context = "render"
    bl_parent_id = "RENDER_PT_hybrid_rt_hybrid"

    def draw(self, context) -> None:
        settings = context.scene.hybrid_rt
        col = _split(self.layout).column()
        col.prop(settings, "shadow_resolution")
        col.prop(settings, "shadow_cascades")
        col.prop(settings, "shadow_bias_texels", text="Bias (texels)")
        col.prop(settings, "shadow_normal_offset", text="Normal Offset (texels)")
        col.prop(settings, "shadow_bias")


class RENDER_PT_hybrid_rt_film(HybridRTPanel, bpy.types.Panel):
    """Film: a transparent background for compositing (hybrid_engine/frame/film.py)."""

    bl_label = "Film"
    bl_context = "render"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context) -> None:
        layout = _split(self.layout)
        layout.column().prop(context.scene.render, "filter_size", text="Pixel Filter")
        layout.column().prop(context.scene.render, "film_transparent", text="Transparent")
        layout.column().prop(context.scene.hybrid_rt, "viewport_scale", text="Viewport Scale")


class RENDER_PT_hybrid_rt_performance(HybridRTPanel, bpy.types.Panel):
    """Performance: Persistent Data, which keeps the extracted scene and the GPU's copy of it
    between final renders (blender_adapter/engine.py), so an animation pays the extraction
    once and then only for what changed. Blender draws it in Cycles' own panel only."""

    bl_label = "Performance"
    bl_context = "render"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context) -> None:
        layout = _split(self.layout)
        layout.column().prop(context.scene.render, "use_persistent_data", text="Persistent Data")


class RENDER_PT_hybrid_rt_diagnostics(HybridRTPanel, bpy.types.Panel):
    """Where rays and time go: the provenance view, the near cube drawn in the viewport and
    the timing report of the frame range."""

    bl_label = "Diagnostics"
    bl_context = "render"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context) -> None:
        layout = _split(self.layout)
        settings = context.scene.hybrid_rt
        col = layout.column(heading="Debug View")
        # The render modes that diagnose (Light Paths > Mode holds them all): the paper's
        # Figure 4 and the views of where rays and time go (hybrid_engine/passes/trace/diagnostic_views.py).
        for view in ("PROVENANCE", *DIAGNOSTIC_VIEWS):
            col.prop_enum(settings, "mode", view)
        row = layout.row()
        row.active = settings.mode == "BOUNCE_PATHS"
        row.prop(settings, "diagnostic_bounce")
        col = layout.column()
        col.prop(context.scene.hybrid_rt, "show_near_cube", icon="CUBE")
        # Per-pass frame times of the scene's frame range (JSON, CSV and a chart).
        col.operator("hybrid_rt.timing_report", icon="TIME")


class VIEWLAYER_PT_hybrid_rt_passes(HybridRTPanel, bpy.types.Panel):
    """The passes this engine writes besides Combined (hybrid_engine/frame/film.py,
    hybrid_engine/passes/film/light_passes.py, vector.py), laid out as Cycles' Passes panels lay them
    out, and no other: Blender's own pass panels list passes this engine does not write."""

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
        col.prop(view_layer, "use_pass_vector")  # 0 with Motion Blur on, as in Cycles
        col.prop(view_layer, "use_pass_mist")
        # Cycles' switch of the same name: the Denoise node's Albedo and Normal guides.
        col.prop(view_layer.hybrid_rt, "denoising_store_passes")
        # Cycles' light passes (its Passes > Light panel), each lobe's Direct, Indirect and Color.
        for lobe in ("diffuse", "glossy", "transmission"):
            col = layout.column(heading=lobe.title(), align=True)
            for kind in ("direct", "indirect", "color"):
                col.prop(view_layer, f"use_pass_{lobe}_{kind}", text=kind.title())
        col = layout.column(heading="Other", align=True)
        col.prop(view_layer, "use_pass_emit", text="Emission")
        col.prop(view_layer, "use_pass_environment")
        col.prop(view_layer, "use_pass_ambient_occlusion", text="Ambient Occlusion")
        # Cryptomatte as Cycles' panel shows it (blender_adapter/engine.py CRYPTOMATTE_FLAGS).
        col = layout.column(heading="Cryptomatte", align=True)
        col.prop(view_layer, "use_pass_cryptomatte_object", text="Object")
        col.prop(view_layer, "use_pass_cryptomatte_material", text="Material")
        col.prop(view_layer, "use_pass_cryptomatte_asset", text="Asset")
        layout.prop(view_layer, "pass_cryptomatte_depth", text="Levels")


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

        # The values the renderer uses, derived with the extractor's own mapping (read-only);
        # images are not read (a draw must not wait for pixels).
        params = material_params(material, textures=False)
        col = layout.column(align=True)
        col.label(text="Derived from the surface shader:")
        grid = col.grid_flow(columns=2, even_columns=True, align=True)
        grid.label(text="Reflectivity")
        grid.label(text=f"{params['reflectivity']:.3f}")
        grid.label(text="Transmission")
        grid.label(text=f"{params['transmission']:.3f}")
        grid.label(text="IOR")
        grid.label(text=f"{params['ior']:.3f}")


class WORLD_PT_hybrid_rt_preview(HybridRTPanel, bpy.types.Panel):
    """The World's preview (blender_adapter/preview.py renders it): Blender's own World
    preview panel is Cycles', and EEVEE has none this engine could share."""

    bl_label = "Preview"
    bl_context = "world"
    bl_options = {"DEFAULT_CLOSED"}

    @classmethod
    def poll(cls, context) -> bool:
        return context.engine == ENGINE_ID and context.world is not None

    def draw(self, context) -> None:
        self.layout.template_preview(context.world)


def draw_preview_thickness(panel, context) -> None:
    """Below the material preview, the paper's per-material thickness (how far behind its
    surface a cube-map ray march finds the material, §3.4), which the preview renders: the
    artist sees the value and its effect together."""
    material = getattr(context, "material", None)
    if context.engine != ENGINE_ID or material is None:
        return
    layout = panel.layout
    layout.use_property_split = True
    layout.use_property_decorate = False
    layout.prop(material.hybrid_rt, "thickness")


_CLASSES = (
    RENDER_PT_hybrid_rt_sampling,
    RENDER_PT_hybrid_rt_light_paths,
    RENDER_PT_hybrid_rt_hybrid,
    RENDER_PT_hybrid_rt_shadows,
    RENDER_PT_hybrid_rt_film,
    RENDER_PT_hybrid_rt_performance,
    RENDER_PT_hybrid_rt_diagnostics,
    VIEWLAYER_PT_hybrid_rt_passes,
    MATERIAL_PT_hybrid_rt,
    WORLD_PT_hybrid_rt_preview,
    DATA_PT_hybrid_rt_light,
)


def register() -> None:
    for cls in _CLASSES:
        bpy.utils.register_class(cls)
    for panel in compatible_panels():
        if ENGINE_ID not in panel.COMPAT_ENGINES:
            panel.COMPAT_ENGINES.add(ENGINE_ID)
            _patched_panels.append(panel)
    bpy.types.MATERIAL_PT_preview.append(draw_preview_thickness)


def unregister() -> None:
    bpy.types.MATERIAL_PT_preview.remove(draw_preview_thickness)
    while _patched_panels:
        _patched_panels.pop().COMPAT_ENGINES.discard(ENGINE_ID)
    for cls in reversed(_CLASSES):
        if cls.is_registered:
            bpy.utils.unregister_class(cls)
