# SPDX-License-Identifier: GPL-3.0-or-later
"""Blender properties: ``scene.hybrid_rt`` (engine settings), ``material.hybrid_rt`` and
``view_layer.hybrid_rt`` (the passes a final render writes beside Blender's own).

The scene settings are *generated* from ``hybrid_engine.scene.settings``: one Blender property
per ``RenderSettings`` field, with the dataclass default, ``FIELD_LIMITS`` as min/max and
``FIELD_DOCS`` as the tooltip. Adding a field to the core therefore adds it to the UI, and
the two cannot disagree on a default or a range. ``settings_from_scene`` turns the stored
values back into the frozen dataclass the renderer compares from frame to frame.

Everything here is stored in the .blend as ID properties of the scene and the material.
"""
from __future__ import annotations

import re
from dataclasses import MISSING, fields

import bpy
import numpy as np

from ..hybrid_engine.scene.materials import DEFAULT_THICKNESS
from ..hybrid_engine.scene.settings import (AUTOMATIC_FIXED, CUBE_MARCH_DOCS, CUBE_MARCH_LABELS, CUBE_MARCHES, FIELD_DOCS, FIELD_LIMITS,
                                      MODE_DOCS, MODE_LABELS, MODES, NEAR_CUBE_MODE_DOCS, NEAR_CUBE_MODE_LABELS,
                                      NEAR_CUBE_MODES, WORLD_LIGHT_DOCS, WORLD_LIGHT_LABELS, WORLD_LIGHTS,
                                      RenderSettings, SettingsError)

# Blender display details the core does not know about (units and sliders).
_FLOAT_SUBTYPES = {
    "near_size": "DISTANCE",
    "near_min": "DISTANCE",
    "near_max": "DISTANCE",
    "cube_far": "DISTANCE",
    "shadow_bias": "DISTANCE",
    "viewport_scale": "FACTOR",
}
LABELS = {
    "mode": "Mode",
    "cube_march": "Search",
    "cube_back_layer": "Back Faces",
    "cube_hidden_exit": "Hidden Exits",
    "near_size": "Near Size",
    "max_depth": "Max Bounces",
    "cube_resolution": "Face Resolution",
    "cube_far": "Far Clip",
    "n_min": "Min Samples",
    "n_max": "Max Samples",
    "shadow_resolution": "Resolution",
    "shadow_bias": "Fixed Bias",
    "shadow_bias_texels": "Bias",
    "shadow_normal_offset": "Normal Offset",
    "cube_resolution_ratio": "Resolution Ratio",
    "shadow_cascades": "Sun Cascades",
    "viewport_scale": "Resolution Scale",
    "render_samples": "Render Samples",
    "viewport_samples": "Viewport Samples",
    "ao_distance": "AO Distance",
    "world_light": "World Light",
    "diffuse_bounces": "Diffuse Bounces",
    "diffuse_rays": "Diffuse Rays",
    "lit_cube": "Lit Cube Map",
    "radiance_cache": "Radiance Cache",
    "bounce_feedback": "Bounce Feedback",
    "near_cube_mode": "Near Cube",
    "frame_budget_ms": "Frame Budget",
    "near_min": "Min Size",
    "diagnostic_bounce": "Bounce",
    "near_max": "Max Size",
    "denoise_viewport": "Viewport",
    "denoise_render": "Render",
}
# The range a slider drags over; typing can go on to the hard limits (FIELD_LIMITS).
SOFT_LIMITS = {
    "near_size": (0.1, 100.0),
    "max_depth": (0, 8),
    "diagnostic_bounce": (1, 8),
    "cube_resolution": (64, 2048),
    "cube_far": (1.0, 10_000.0),
    "n_min": (4, 256),
    "n_max": (4, 512),
    "shadow_resolution": (256, 4096),
    "shadow_bias": (0.0, 0.2),
    "shadow_bias_texels": (0.0, 4.0),
    "shadow_normal_offset": (0.0, 4.0),
    "cube_resolution_ratio": (0.1, 1.0),
    "shadow_cascades": (0, 3),
    "viewport_scale": (0.25, 1.0),
    "render_samples": (1, 64),
    "ao_distance": (0.0, 10.0),
    "viewport_samples": (1, 256),
    "frame_budget_ms": (5.0, 2000.0),
    "near_min": (0.1, 100.0),
    "near_max": (0.1, 100.0),
    "diffuse_bounces": (0, 4),
    "diffuse_rays": (1, 8),
}
# cube_far is kept past near_size by this factor when either is edited.
_CUBE_FAR_MARGIN = 1.01

THICKNESS_DOC = (
    "How far behind its visible surface this material extends, as seen by rays marched "
    "through the cube map (paper section 3.4). 0: infinitely thin, a ray that passes behind "
    "the stored surface goes on past it; 1: solid all the way to the cube map's far plane, "
    "any ray behind the surface hits it"
)


def _pushing(edited: str, other: str, *, above: bool, margin: float = 1.0):
    """An update callback that keeps ``edited`` below (``above`` False) or above ``other``
    by pushing ``other`` along, as Blender's frame range does: raising a minimum past its
    maximum raises the maximum. ``margin`` > 1 keeps the two strictly apart."""
    strict = margin > 1.0

    def update(settings, _context) -> None:
        value, limit = getattr(settings, edited), getattr(settings, other)
        if value <= 0 or limit <= 0:
            return  # 0 is Automatic (near size, far clip): placed apart each frame by the core
        crossed = (value < limit or strict and value == limit) if above else \
            (value > limit or strict and value == limit)
        if crossed:  # the pushed value no longer crosses back, so its own update stops
            setattr(settings, other, value if not strict else value / margin if above else value * margin)
    return update


# String fields of RenderSettings: their allowed values and each value's tooltip.
_ENUMS = {"mode": (MODES, MODE_LABELS, MODE_DOCS), "cube_march": (CUBE_MARCHES, CUBE_MARCH_LABELS, CUBE_MARCH_DOCS),
          "near_cube_mode": (NEAR_CUBE_MODES, NEAR_CUBE_MODE_LABELS, NEAR_CUBE_MODE_DOCS),
          "world_light": (WORLD_LIGHTS, WORLD_LIGHT_LABELS, WORLD_LIGHT_DOCS)}

_UPDATES = {
    "n_min": _pushing("n_min", "n_max", above=False),
    "n_max": _pushing("n_max", "n_min", above=True),
    "near_min": _pushing("near_min", "near_max", above=False),
    "near_max": _pushing("near_max", "near_min", above=True),
    # The cube map starts at the near cube's faces: its far plane must lie beyond them.
    "near_size": _pushing("near_size", "cube_far", above=False, margin=_CUBE_FAR_MARGIN),
    "cube_far": _pushing("cube_far", "near_size", above=True, margin=_CUBE_FAR_MARGIN),
}


def _property_for(name: str, default):
    """One bpy property definition for a RenderSettings field."""
    label = LABELS.get(name, name.replace("_", " ").title())
    doc = FIELD_DOCS[name]
    if name in _ENUMS:
        values, labels, docs = _ENUMS[name]
        items = [(value, labels[value], docs[value]) for value in values]
        return bpy.props.EnumProperty(name=label, description=doc, items=items, default=default)
    if isinstance(default, bool):
        return bpy.props.BoolProperty(name=label, description=doc, default=default)
    lo, hi = FIELD_LIMITS[name]
    soft_lo, soft_hi = SOFT_LIMITS.get(name, (lo, hi))
    extra = {}
    if name in _UPDATES:
        extra["update"] = _UPDATES[name]
    if isinstance(default, int):
        return bpy.props.IntProperty(
            name=label, description=doc, default=default, min=int(lo), max=int(hi),
            soft_min=int(soft_lo), soft_max=int(soft_hi), **extra
        )
    if isinstance(default, float):
        return bpy.props.FloatProperty(
            name=label, description=doc, default=default, min=float(lo), max=float(hi),
            soft_min=float(soft_lo), soft_max=float(soft_hi),
            subtype=_FLOAT_SUBTYPES.get(name, "NONE"), precision=3, **extra,
        )
    raise TypeError(f"RenderSettings.{name}: no Blender property for {type(default).__name__}")


def _automatic_toggle(name: str):
    """The Automatic switch of a setting whose 0 means Automatic (``AUTOMATIC_FIXED``): on
    stores 0 and keeps the fixed value in ``<name>_fixed``, off brings that value back. The
    setting itself stays the one stored value, so files that set it before it could follow
    the scene keep their value, and files that never set it follow the scene."""
    fixed = f"{name}_fixed"

    def get(settings) -> bool:
        return getattr(settings, name) <= 0

    def set_(settings, automatic: bool) -> None:
        value = getattr(settings, name)
        if automatic and value > 0:
            setattr(settings, fixed, value)
            setattr(settings, name, type(value)(0))
        elif not automatic and value <= 0:
            setattr(settings, name, getattr(settings, fixed))

    label = LABELS.get(name, name)
    return bpy.props.BoolProperty(
        name="Automatic", get=get, set=set_,
        description=f"{label} follows the scene and the output (the value shown is the last frame's); "
        "off: the value you set")


def _fixed_value(name: str):
    """Where ``_automatic_toggle`` keeps the fixed value while Automatic is on."""
    default = AUTOMATIC_FIXED[name]
    lo, hi = FIELD_LIMITS[name]
    lo = 16 if name == "cube_resolution" else 0.01
    if isinstance(default, int):
        return bpy.props.IntProperty(name=LABELS[name], default=default, min=int(lo), max=int(hi),
                                     options={"HIDDEN"})
    return bpy.props.FloatProperty(name=LABELS[name], default=default, min=lo, max=hi, subtype="DISTANCE",
                                   options={"HIDDEN"})


def _redraw_3d_views(_settings, context) -> None:
    screen = getattr(context, "screen", None)
    for area in (screen.areas if screen is not None else ()):
        if area.type == "VIEW_3D":
            area.tag_redraw()


def _scene_annotations() -> dict:
    annotations = {}
    for f in fields(RenderSettings):
        if f.default is MISSING:
            raise TypeError(f"RenderSettings.{f.name} needs a default to become a Blender property")
        annotations[f.name] = _property_for(f.name, f.default)
    for name in AUTOMATIC_FIXED:
        annotations[f"{name}_auto"] = _automatic_toggle(name)
        annotations[f"{name}_fixed"] = _fixed_value(name)
    # The budget as artists also think of it: a frame rate, stored as the milliseconds only.
    lo, hi = FIELD_LIMITS["frame_budget_ms"]
    soft_lo, soft_hi = SOFT_LIMITS.get("frame_budget_ms", (lo, hi))
    annotations["frame_budget_fps"] = bpy.props.FloatProperty(
        name="Target FPS", precision=2, min=1000.0 / hi, max=1000.0 / lo,
        soft_min=1000.0 / soft_hi, soft_max=1000.0 / soft_lo,
        get=lambda settings: 1000.0 / settings.frame_budget_ms,
        set=lambda settings, fps: setattr(settings, "frame_budget_ms", 1000.0 / fps),
        description="Frame Budget as frames per second (1000 / Frame Budget): setting one sets the other")
    # Interface state saved with the file, not a render setting (operators/near_cube_overlay.py).
    annotations["show_near_cube"] = bpy.props.BoolProperty(
        name="Show Near Cube", default=False, update=_redraw_3d_views,
        description="Draw the near cube's bounds in the 3D viewport: what lies inside is traced "
        "exactly, what lies outside is looked up in the cube map")
    return annotations


HybridRTSceneSettings = type(
    "HybridRTSceneSettings",
    (bpy.types.PropertyGroup,),
    {
        "__doc__": "Hybrid RT render settings (one property per hybrid_engine RenderSettings field)",
        "__annotations__": _scene_annotations(),
    },
)


def _tag_material_changed(settings, _context) -> None:
    # A custom property edit does not by itself reach depsgraph.updates; tag the material so
    # the viewport re-reads it on the next redraw.
    settings.id_data.update_tag()


class HybridRTMaterialSettings(bpy.types.PropertyGroup):
    """Per-material Hybrid RT settings."""

    thickness: bpy.props.FloatProperty(
        name="Thickness",
        description=THICKNESS_DOC,
        default=DEFAULT_THICKNESS,
        min=0.0,
        max=1.0,
        subtype="FACTOR",
        update=_tag_material_changed,
    )


def _update_render_passes(_settings, context) -> None:
    # The compositor's Render Layers node shows the passes the engine registers
    # (engine.update_render_passes); ask it again when the passes asked for change.
    view_layer = getattr(context, "view_layer", None)
    if view_layer is not None:
        view_layer.update_render_passes()


class HybridRTViewLayerSettings(bpy.types.PropertyGroup):
    """Per-view-layer Hybrid RT settings: passes Blender's view layer has no switch for."""

    denoising_store_passes: bpy.props.BoolProperty(
        name="Denoising Data",
        description="Store the Denoising Albedo and Denoising Normal passes, as Cycles' Denoising Data "
        "does, for the compositor's Denoise node",
        default=False,
        update=_update_render_passes,
    )


_CLASSES = (HybridRTSceneSettings, HybridRTMaterialSettings, HybridRTViewLayerSettings)
_POINTERS = ((bpy.types.Scene, HybridRTSceneSettings), (bpy.types.Material, HybridRTMaterialSettings),
             (bpy.types.ViewLayer, HybridRTViewLayerSettings))


def settings_from_scene(scene) -> RenderSettings:
    """The scene's stored settings as the core's frozen dataclass.

    Raises ``hybrid_engine.scene.settings.SettingsError`` naming the settings by the labels the
    artist sees when the stored values are inconsistent (e.g. a cube-map far plane inside
    the near cube, set from a script: the panel's fields push each other apart).
    """
    stored = scene.hybrid_rt
    values = {}
    for f in fields(RenderSettings):
        value = getattr(stored, f.name)
        if isinstance(value, float):
            # Blender keeps floats as float32: take the shortest decimal that round-trips it,
            # so an untouched 0.02 reads back as 0.02 and compares equal to the core default
            # (the renderer decides what to rebuild by comparing settings).
            value = float(np.format_float_positional(np.float32(value)))
        values[f.name] = value
    try:
        return RenderSettings(**values)
    except SettingsError as exc:
        raise SettingsError(labelled(str(exc))) from None


def labelled(message: str) -> str:
    """A core message with each setting's identifier replaced by its label in quotes."""
    for name in sorted(LABELS, key=len, reverse=True):  # n_max before max, cube_far before far
        message = re.sub(rf"\b{name}\b", f"'{LABELS[name]}'", message)
    return message


def register() -> None:
    for cls in _CLASSES:
        bpy.utils.register_class(cls)
    for owner, group in _POINTERS:
        owner.hybrid_rt = bpy.props.PointerProperty(type=group, name="Hybrid RT")


def unregister() -> None:
    for owner, _group in reversed(_POINTERS):
        if hasattr(owner, "hybrid_rt"):
            del owner.hybrid_rt
    for cls in reversed(_CLASSES):
        if cls.is_registered:
            bpy.utils.unregister_class(cls)
