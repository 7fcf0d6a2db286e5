# SPDX-License-Identifier: GPL-3.0-or-later
"""The Light properties panel: exactly the lamp controls the engine renders.

EEVEE's light panels show controls this engine does not read (soft falloff, area spread,
shadow jitter and resolution limits...), which would change nothing in the image. This
panel draws only what blender_adapter/export/lights.py reads: colour, temperature, power or
strength, exposure, normalize, the lamp's size (point and spot radius, sun angle, area
shape and size, which soften shadows and widen highlights) and whether the lamp casts
shadows. The spot's cone is Blender's own Spot Shape panel, which this engine shows too.
"""
from __future__ import annotations

import bpy

ENGINE_ID = "HYBRID_RT"

# The controls drawn for each lamp type, in order (each one read by the exporter).
CONTROLS = {
    "POINT": ("color", "use_temperature", "temperature", "energy", "exposure", "normalize", "shadow_soft_size",
              "use_shadow"),
    "SPOT": ("color", "use_temperature", "temperature", "energy", "exposure", "normalize", "shadow_soft_size",
             "use_shadow"),
    "SUN": ("color", "use_temperature", "temperature", "energy", "exposure", "normalize", "angle", "use_shadow"),
    "AREA": ("color", "use_temperature", "temperature", "energy", "exposure", "normalize", "shape", "size",
             "size_y", "use_shadow"),
}
_LABELS = {"energy": None, "shadow_soft_size": "Radius", "size_y": "Size Y", "use_shadow": "Cast Shadows"}


def controls(light) -> tuple[str, ...]:
    """The properties drawn for ``light`` (size_y only for rectangles and ellipses, the
    temperature only when it is in use)."""
    names = CONTROLS.get(light.type, ())
    if light.type == "AREA" and light.shape not in ("RECTANGLE", "ELLIPSE"):
        names = tuple(n for n in names if n != "size_y")
    if not light.use_temperature:
        names = tuple(n for n in names if n != "temperature")
    return names


class DATA_PT_hybrid_rt_light(bpy.types.Panel):
    bl_label = "Light"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "data"

    @classmethod
    def poll(cls, context) -> bool:
        return context.engine == ENGINE_ID and context.light is not None

    def draw(self, context) -> None:
        layout = self.layout
        light = context.light
        layout.row().prop(light, "type", expand=True)
        layout.use_property_split = True
        layout.use_property_decorate = False
        col = layout.column()
        for name in controls(light):
            label = _LABELS.get(name)
            if label is None:
                col.prop(light, name)
            else:
                col.prop(light, name, text=label)
