# SPDX-License-Identifier: GPL-3.0-or-later
"""Every Blender render feature, and what Hybrid RT does with it: the one list behind the
README's feature table and behind the message the artist gets when a scene uses a feature
the engine does not render.

A feature Blender offers and the engine drops without a word is a wrong picture the artist
cannot explain. Each entry says how the engine treats the feature (supported, approximated
and how, or unsupported); an entry with a ``message`` also knows how to find the feature in
a scene (``used``), and ``tell_used_features`` names it to the artist once per render through
``messages.tell``. tests/test_features.py holds the README's table to this list, so the
documentation and the messages cannot drift apart.
"""
from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass

from . import messages

SUPPORTED, APPROXIMATED, UNSUPPORTED = "supported", "approximated", "unsupported"

# Object types the engine turns into triangles (through Blender's own conversion to a mesh).
MESH_LIKE_TYPES = frozenset({"MESH", "CURVE", "SURFACE", "META", "FONT"})
# Object types the engine does not draw, by the name Blender's UI gives them.
UNRENDERED_TYPES = {"CURVES": "Hair Curves", "VOLUME": "Volume", "POINTCLOUD": "Point Cloud",
                    "GREASEPENCIL": "Grease Pencil"}
NAMES_SHOWN = 3  # objects named in one message; the rest are counted


@dataclass(frozen=True)
class Feature:
    """One Blender feature: its name as Blender's interface shows it, how the engine treats
    it, and (for what it does not render fully) the message the artist gets and how to tell
    a scene uses it: ``used(scene, depsgraph, final)`` returns the names of what uses it
    (objects, lamps, the camera), empty when nothing does. ``final``: an F12 render or a
    timing report, which may afford a walk over every object; the viewport asks only for
    what settings alone reveal."""

    name: str
    status: str
    treatment: str
    message: str | None = None
    used: Callable[[object, object, bool], list[str]] | None = None


def _named(names: list[str]) -> str:
    shown = ", ".join(repr(n) for n in names[:NAMES_SHOWN])
    return shown + (f" and {len(names) - NAMES_SHOWN} more" if len(names) > NAMES_SHOWN else "")


def _setting(owner: str, flag: str, label: str, *, final_only: bool = False):
    def used(scene, _depsgraph, final) -> list[str]:
        if final_only and not final:
            return []
        return [label] if getattr(getattr(scene, owner), flag, False) else []
    return used


def _freestyle(scene, depsgraph, _final) -> list[str]:
    if not scene.render.use_freestyle:
        return []
    return [depsgraph.view_layer.name] if depsgraph.view_layer.use_freestyle else []


def _objects(depsgraph) -> Iterator:
    """Each evaluated object once (not each instance of it: a walk over the instances of a
    scattered forest would cost more than the answer is worth)."""
    yield from depsgraph.objects


def _object_types(kind: str):
    def used(_scene, depsgraph, final) -> list[str]:
        if not final:
            return []
        return sorted({obj.name for obj in _objects(depsgraph) if obj.type == kind})
    return used


def _object_flag(flag: str, value: bool):
    def used(_scene, depsgraph, final) -> list[str]:
        if not final:
            return []
        return sorted({obj.name for obj in _objects(depsgraph)
                       if obj.type in MESH_LIKE_TYPES and getattr(obj, flag, not value) == value})
    return used


def _emitter_linking(scene, depsgraph, final) -> list[str]:
    """Objects other than lamps with a receiver or blocker collection (an emissive mesh's
    linking): rendered, but not in every kind of light (the feature's message)."""
    if not final:
        return []
    names = set()
    for obj in _objects(depsgraph):
        if obj.type == "LIGHT":
            continue
        linking = getattr(obj, "light_linking", None)
        if linking is not None and (linking.receiver_collection is not None or linking.blocker_collection is not None):
            names.add(obj.name)
    return sorted(names)


def _world_volume(scene, _depsgraph, _final) -> list[str]:
    world = scene.world
    tree = getattr(world, "node_tree", None) if world is not None else None
    if tree is None:
        return []
    output = tree.get_output_node("ALL")
    socket = output.inputs.get("Volume") if output is not None else None
    return [world.name] if socket is not None and socket.is_linked else []


FEATURES: tuple[Feature, ...] = (
    # Camera and film
    Feature("Perspective and Orthographic cameras", SUPPORTED,
            "Focal length, sensor fit, shift, clipping, the render region."),
    Feature("Panoramic cameras", UNSUPPORTED,
            "The render stops with an error naming the camera."),
    Feature("Depth of Field", SUPPORTED,
            "A thin lens as Cycles': focus object or distance, F-stop, blades, rotation and ratio, "
            "one aperture point per sample, in final renders and in the viewport's camera view."),
    Feature("Motion Blur", APPROXIMATED,
            "Final renders: objects, the camera and deforming meshes move over the shutter "
            "(Position, Shutter), interpolated from three sub-frame steps, one time per sample; a "
            "mesh whose topology changes keeps the frame's shape, and the artist is told (*Motion "
            "Blur does not blur a change of topology yet ('…'): the shape is the frame's, only the "
            "motion is blurred*); no shutter curve or rolling shutter."),
    Feature("Stereoscopy", UNSUPPORTED, "One view is rendered; the panel is hidden.",
            "Stereoscopy is not rendered: every view gets the same image",
            _setting("render", "use_multiview", "Stereoscopy")),
    Feature("Freestyle", UNSUPPORTED, "No strokes are drawn.",
            "Freestyle is not rendered: no strokes are drawn (view layer {names})", _freestyle),
    Feature("Film: Pixel Filter, Transparent", SUPPORTED,
            "The filter width spreads the accumulated samples; a transparent film keeps alpha."),
    Feature("Color Management", SUPPORTED, "View transform, look, exposure and gamma, as Blender applies them."),
    # Geometry
    Feature("Meshes, curves, surfaces, metaballs and text", SUPPORTED,
            "As Blender evaluates them (modifiers, geometry nodes), turned into triangles."),
    Feature("Instances", SUPPORTED,
            "Collection, geometry-nodes and particle instances share one mesh on the GPU."),
    Feature("Hair Curves", UNSUPPORTED, "Not drawn.",
            "Hair Curves objects {names} are not rendered", _object_types("CURVES")),
    Feature("Volume objects", UNSUPPORTED, "Not drawn.",
            "Volume objects {names} are not rendered", _object_types("VOLUME")),
    Feature("Point Clouds", UNSUPPORTED, "Not drawn.",
            "Point Cloud objects {names} are not rendered", _object_types("POINTCLOUD")),
    Feature("Grease Pencil", UNSUPPORTED, "Not drawn.",
            "Grease Pencil objects {names} are not rendered", _object_types("GREASEPENCIL")),
    Feature("Non-finite vertices", APPROXIMATED,
            "Triangles with a NaN or infinite corner are skipped, with a message; the rest of "
            "the object renders."),
    # Objects
    Feature("Ray Visibility", UNSUPPORTED, "Every object is seen by every ray.",
            "Ray Visibility: objects {names} are hidden from camera rays in Blender, but every "
            "ray sees them here", _object_flag("visible_camera", False)),
    Feature("Holdout", UNSUPPORTED, "Holdout objects render as ordinary objects.",
            "Holdout objects {names} render as ordinary objects", _object_flag("is_holdout", True)),
    Feature("Shadow Catcher", UNSUPPORTED, "Shadow catchers render as ordinary objects.",
            "Shadow Catcher objects {names} render as ordinary objects", _object_flag("is_shadow_catcher", True)),
    # Light
    Feature("Lamps: Point, Sun, Spot, Area", SUPPORTED,
            "Power, exposure, temperature, Normalize, size and shape, spot cone and blend, "
            "shadows (shadow maps with soft penumbrae)."),
    Feature("Light Linking", SUPPORTED,
            "A lamp's Receiver Collection limits what it lights (the G-buffer, BVH and cube-map "
            "hits alike) and its Blocker Collection what casts its shadow maps, with Blender's "
            "Include and Exclude states."),
    Feature("Light Linking of emissive objects", APPROXIMATED,
            "As Cycles links mesh lights: an emissive object's Receiver Collection limits what its "
            "light reaches (the diffuse light's sampling of emitters; a reflection or refraction "
            "shows it only where it lights the surface the pixel shows; the lit cube map's bounces "
            "carry it only to its receivers) and its Blocker Collection what shadows it; the camera "
            "sees it whatever its linking. The one-ray diffuse light of surfaces seen in "
            "reflections is not linked.",
            "Light Linking of {names}: the diffuse light of surfaces seen in reflections reaches "
            "every object",
            _emitter_linking),
    Feature("Emissive materials", SUPPORTED, "Emissive triangles light the scene (sampled by power)."),
    Feature("World node graphs", SUPPORTED,
            "Background, Environment Texture (equirectangular, mirror ball), the Sky Texture (all "
            "four models; the scattering models' sun disc as a sun lamp, not drawn), and the colour, "
            "vector and texture nodes, baked on the GPU into the sky that rays, irradiance and rough "
            "reflections read."),
    Feature("World Volume", UNSUPPORTED, "No fog or atmosphere.",
            "World {names}: the Volume shader is not rendered", _world_volume),
    # Materials
    Feature("Shader node graphs", SUPPORTED,
            "Evaluated per shading point on the GPU (G-buffer, cube-map and BVH hits) as GLSL "
            "written out per graph shape, with one interpreter behind it: Principled, Diffuse, "
            "Glossy, Glass, Refraction, Transparent, Emission, Mix and Add Shader; Image, Noise, "
            "Voronoi, Wave, Checker, Brick, Gradient, Magic and White Noise textures; Math, "
            "Vector Math, Mix, Color Ramp, curves, colour adjustments, Map Range, Clamp, Mapping,"
            " Vector Rotate, Separate and Combine; input nodes; groups, reroutes and muted nodes "
            "as Blender evaluates them. A value edit is an upload, never a shader compile; a new "
            "link compiles once. A Glossy mixed over a diffuse base is that base's coat, with its"
            " own roughness and weight; other mixes of shaders mix their parameters."),
    Feature("Bump node", APPROXIMATED,
            "Evaluated as Cycles does (the Height at the shading point and one Filter Width along "
            "the footprint's two axes), in the G-buffer and at BVH and cube-map hits (there from "
            "the UV directions the cube faces store); a stepped Height (a Checker) at a wide "
            "Filter Width differs from Cycles."),
    Feature("Color Attribute and Attribute nodes", SUPPORTED,
            "Vertex colours (point or face corner, byte colours converted to linear as Cycles "
            "does) and named float, vector and colour attributes on points, corners and faces, "
            "interpolated wherever a surface is shaded; Object and Instancer attributes from "
            "custom properties and property paths. Only the attributes some material reads are "
            "exported."),
    Feature("Alpha: Principled Alpha, alpha images, Transparent BSDF", SUPPORTED,
            "Stochastic coverage in the G-buffer, cube map, shadow maps, BVH traversal and Vector pass, "
            "converging to Cycles' over the samples; Blended renders the same way, with a message."),
    Feature("Per-material Thickness", SUPPORTED, "The paper's cube-map thickness, in the Material panel."),
    Feature("Missing images", APPROXIMATED, "Magenta, as Blender's engines render them, with a message."),
    # Output
    Feature("Passes: Combined, Depth, Normal, Mist, Denoising Data, Cryptomatte, the light passes "
            "(Diffuse / Glossy / Transmission Direct, Indirect, Color; Emission, Environment, AO)", SUPPORTED,
            "Under Cycles' names, for the compositor (its Denoise and Cryptomatte nodes included); "
            "Cycles writes no Shadow pass, so none is offered."),
    Feature("Passes: Vector", SUPPORTED,
            "As Cycles writes it: the motion in pixels towards the previous frame (xy) and from the next "
            "(zw) of objects, deforming meshes and the camera, the mean over the samples that hit; "
            "with Motion Blur on the pass is 0, as in Cycles. The other frames' camera keeps this "
            "frame's lens."),
    Feature("Persistent Data", SUPPORTED, "The extracted scene and its GPU copy stay between renders."),
    Feature("Material, World and Light previews", SUPPORTED,
            "Rendered on Blender's preview scene with one sample and a small cube map; the "
            "material preview shows the thickness."),
)


def used_features(scene, depsgraph, final: bool) -> list[tuple[Feature, list[str]]]:
    """Each feature with a message that the scene uses, with the names of what uses it."""
    found = []
    for feature in FEATURES:
        if feature.used is None:
            continue
        names = feature.used(scene, depsgraph, final)
        if names:
            found.append((feature, names))
    return found


def tell_used_features(scene, depsgraph, final: bool) -> None:
    """Name to the artist (``messages.tell``) every feature the scene uses that the engine
    does not render fully."""
    for feature, names in used_features(scene, depsgraph, final):
        messages.tell(feature.message.format(names=_named(names)))


def feature_table() -> str:
    """The README's feature table (tests/test_features.py keeps the README equal to it)."""
    lines = ["| Blender feature | Hybrid RT | What happens |", "| --- | --- | --- |"]
    for feature in FEATURES:
        treatment = feature.treatment
        if feature.message is not None:
            example = feature.message.format(names="'…'")
            treatment += f" Message: *{example}*."
        lines.append(f"| {feature.name} | {feature.status} | {treatment} |")
    return "\n".join(lines)
