# SPDX-License-Identifier: GPL-3.0-or-later
"""A scene of procedural materials: Hybrid RT, EEVEE and Cycles side by side, and Hybrid RT
again with every procedural baked to images first (issue 38, Numbers: the procedural scene).

Usage: python scripts/measure_procedural.py [--width 320 --height 180] [--cycles-samples 256]
                                            [--eevee-samples 32] [--bake-size 256]
                                            [--references DIR] [--json FILE] [--sheet FILE]

The scene is built here, in bpy, from materials an artist makes every day:

* a wood floor: Noise distorting a Wave (Rings) through a Color Ramp;
* a brick wall: Brick Texture;
* a lacquered sphere: Mix Shader of a Diffuse and a Glossy BSDF by a Fresnel;
* a bumped wall: Noise into a Bump node into the Principled Normal;
* vertex-coloured props: a Color Attribute into Base Color;
* scattered instances with random colours: linked duplicates whose Object Info Random picks a
  colour from a Color Ramp.

It renders through Blender's render path by Cycles (denoised: the reference), EEVEE (the
peer) and Hybrid RT, then bakes every procedural with Cycles in the same process
(``bpy.ops.object.bake``: the base colour, ROUGHNESS and tangent NORMAL into float images,
one set per object: the instances are made single-user first, as each has its own colour),
replaces each material by a Principled of those images, and renders Hybrid RT again. Each
step is the one that hands the Principled what the procedural gave it (``bake_to_images``):

* the colour is baked as EMIT, from an Emission fed by the socket that gives the material
  its diffuse colour (``_albedo_input``). Cycles' DIFFUSE COLOR bake is not the base colour:
  it is the diffuse closure's weight, which Cycles' Principled scales by one minus its
  specular layer's albedo and a Mix Shader by its factor (here a Fresnel), both seen along
  the normal (about 0.96 for IOR 1.5). The baked Principled applies its specular layer
  again, so that bake renders every material a few per cent darker, in Cycles as well;
* the colour image is float and Linear Rec.709 (the working space: the bake writes
  scene-linear values, read back as they are), roughness and normal are Non-Color (data);
* the normal is baked in tangent space and read by a Normal Map node at strength 1, its
  inverse;
* the bake anti-aliases with ``BAKE_SAMPLES`` and extends each island by ``BAKE_MARGIN``
  texels, as an artist's bake does: a filtered read at a seam stays in the island's colour
  at the finer mip levels, while the coarse levels that a rough glossy ray's wide cone
  reads (on the cubes and instances, whose islands leave most of the image empty) average
  in the black outside the islands, as they would for any such texture. Diffuse paths read
  at the camera's footprint (trace_ray.glsl ``PATH_TEXTURE_BLUR``), so their bounced light
  keeps the islands' colour.

It prints FLIP to Cycles for each image (LDR: clamped, sRGB-encoded, as docs/PICTURES.md) and
the bars: Hybrid RT's FLIP at or below EEVEE's, and within ``BAKED_TOLERANCE`` of the baked
variant's. What Hybrid RT reported while rendering (nodes it does not evaluate) is printed
with the numbers. ``--references`` keeps the Cycles and EEVEE images for the next run (the
key names the scene's version: change ``SCENE_VERSION`` with the scene).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from addon_loader import REPO_ROOT, load_addon
from make_pictures import display_bytes, flip_map, labelled, render_cycles, render_eevee, render_hybrid, write_png
from measure_light import cached, cached_eevee

SCENE_VERSION = 1  # part of the cached references' key: bump it when the scene changes
DEFAULT_SIZE = (320, 180)
CYCLES_SAMPLES = 256
EEVEE_SAMPLES = 32
BAKE_SIZE = 256
BAKE_SAMPLES = 4  # anti-aliasing of the baked texels: colour, roughness and normal need no light
BAKE_MARGIN = 4  # texels each UV island is extended by (seams read by a filtered lookup)
BAKED_TOLERANCE = 0.03  # the bar: |FLIP(procedural) - FLIP(baked)| <= 0.03
INSTANCES = 9


# ---------------------------------------------------------------------------------------------
# The scene
# ---------------------------------------------------------------------------------------------
def _material(name: str):
    """A material whose tree holds only its Material Output (the caller wires the rest)."""
    import bpy

    material = bpy.data.materials.new(name)
    nodes = material.node_tree.nodes
    for node in [n for n in nodes if n.type != "OUTPUT_MATERIAL"]:
        nodes.remove(node)
    return material, nodes, material.node_tree.links, nodes["Material Output"]


def _ramp(node, stops: list[tuple[float, tuple[float, float, float]]]) -> None:
    elements = node.color_ramp.elements
    while len(elements) > len(stops):
        elements.remove(elements[-1])
    while len(elements) < len(stops):
        elements.new(0.5)
    for element, (position, colour) in zip(elements, stops):
        element.position = position
        element.color = (*colour, 1.0)


def wood_material():
    """Noise distorting Wave rings, through a Color Ramp of browns; roughness from the rings."""
    material, nodes, links, output = _material("wood floor")
    coords = nodes.new("ShaderNodeTexCoord")
    mapping = nodes.new("ShaderNodeMapping")
    mapping.inputs["Scale"].default_value = (0.6, 3.0, 1.0)
    links.new(coords.outputs["Object"], mapping.inputs["Vector"])
    noise = nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 3.0
    noise.inputs["Detail"].default_value = 3.0
    wave = nodes.new("ShaderNodeTexWave")
    wave.wave_type = "RINGS"
    wave.rings_direction = "Y"
    wave.inputs["Scale"].default_value = 2.5
    wave.inputs["Distortion"].default_value = 6.0
    wave.inputs["Detail"].default_value = 2.0
    mix = nodes.new("ShaderNodeMix")
    mix.data_type = "VECTOR"
    mix.inputs["Factor"].default_value = 0.15
    links.new(mapping.outputs["Vector"], mix.inputs[4])
    links.new(noise.outputs["Color"], mix.inputs[5])
    links.new(mapping.outputs["Vector"], noise.inputs["Vector"])
    links.new(mix.outputs[1], wave.inputs["Vector"])
    ramp = nodes.new("ShaderNodeValToRGB")
    _ramp(ramp, [(0.2, (0.16, 0.07, 0.025)), (0.8, (0.55, 0.3, 0.12))])
    links.new(wave.outputs["Fac"], ramp.inputs["Fac"])
    bsdf = nodes.new("ShaderNodeBsdfPrincipled")
    links.new(ramp.outputs["Color"], bsdf.inputs["Base Color"])
    rough = nodes.new("ShaderNodeMapRange")
    rough.inputs["To Min"].default_value = 0.3
    rough.inputs["To Max"].default_value = 0.55
    links.new(wave.outputs["Fac"], rough.inputs["Value"])
    links.new(rough.outputs["Result"], bsdf.inputs["Roughness"])
    links.new(bsdf.outputs["BSDF"], output.inputs["Surface"])
    return material


def brick_material():
    material, nodes, links, output = _material("bricks")
    coords = nodes.new("ShaderNodeTexCoord")
    brick = nodes.new("ShaderNodeTexBrick")
    brick.inputs["Color1"].default_value = (0.45, 0.12, 0.06, 1.0)
    brick.inputs["Color2"].default_value = (0.3, 0.09, 0.05, 1.0)
    brick.inputs["Mortar"].default_value = (0.6, 0.58, 0.55, 1.0)
    brick.inputs["Scale"].default_value = 1.5
    links.new(coords.outputs["Object"], brick.inputs["Vector"])
    bsdf = nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.inputs["Roughness"].default_value = 0.8
    links.new(brick.outputs["Color"], bsdf.inputs["Base Color"])
    links.new(bsdf.outputs["BSDF"], output.inputs["Surface"])
    return material


def lacquer_material():
    """A red lacquer: Diffuse and a sharp Glossy mixed by a Fresnel of IOR 1.5."""
    material, nodes, links, output = _material("lacquer")
    diffuse = nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (0.6, 0.04, 0.03, 1.0)
    glossy = nodes.new("ShaderNodeBsdfGlossy")
    glossy.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    glossy.inputs["Roughness"].default_value = 0.08
    fresnel = nodes.new("ShaderNodeFresnel")
    fresnel.inputs["IOR"].default_value = 1.5
    mix = nodes.new("ShaderNodeMixShader")
    links.new(fresnel.outputs["Fac"], mix.inputs["Fac"])
    links.new(diffuse.outputs["BSDF"], mix.inputs[1])
    links.new(glossy.outputs["BSDF"], mix.inputs[2])
    links.new(mix.outputs["Shader"], output.inputs["Surface"])
    return material


def bumped_material():
    """Plaster with a Noise relief through a Bump node."""
    material, nodes, links, output = _material("bumped plaster")
    noise = nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 6.0
    noise.inputs["Detail"].default_value = 4.0
    bump = nodes.new("ShaderNodeBump")
    bump.inputs["Strength"].default_value = 0.6
    bump.inputs["Distance"].default_value = 0.05
    links.new(noise.outputs["Fac"], bump.inputs["Height"])
    bsdf = nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.inputs["Base Color"].default_value = (0.7, 0.68, 0.62, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.7
    links.new(bump.outputs["Normal"], bsdf.inputs["Normal"])
    links.new(bsdf.outputs["BSDF"], output.inputs["Surface"])
    return material


def vertex_colour_material():
    material, nodes, links, output = _material("vertex colours")
    attribute = nodes.new("ShaderNodeVertexColor")
    attribute.layer_name = "Col"
    bsdf = nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.inputs["Roughness"].default_value = 0.5
    links.new(attribute.outputs["Color"], bsdf.inputs["Base Color"])
    links.new(bsdf.outputs["BSDF"], output.inputs["Surface"])
    return material


def random_colour_material():
    """Object Info Random through a rainbow Color Ramp: each instance its own colour."""
    material, nodes, links, output = _material("random colours")
    info = nodes.new("ShaderNodeObjectInfo")
    ramp = nodes.new("ShaderNodeValToRGB")
    _ramp(ramp, [(0.0, (0.8, 0.1, 0.1)), (0.33, (0.9, 0.75, 0.1)), (0.66, (0.1, 0.6, 0.2)), (1.0, (0.1, 0.2, 0.8))])
    links.new(info.outputs["Random"], ramp.inputs["Fac"])
    bsdf = nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.inputs["Roughness"].default_value = 0.35
    links.new(ramp.outputs["Color"], bsdf.inputs["Base Color"])
    links.new(bsdf.outputs["BSDF"], output.inputs["Surface"])
    return material


def _add(op, material, **kwargs):
    """A primitive added by ``op`` with ``material``; returns the object."""
    import bpy

    op(**kwargs)
    obj = bpy.context.object
    obj.data.materials.append(material)
    return obj


def _paint_vertex_colours(obj) -> None:
    """A Color Attribute ``Col`` on the corners: a colour from each vertex's position."""
    mesh = obj.data
    attribute = mesh.color_attributes.new("Col", "FLOAT_COLOR", "CORNER")
    positions = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", positions)
    positions = positions.reshape(-1, 3)
    corners = np.empty(len(mesh.loops), np.int32)
    mesh.loops.foreach_get("vertex_index", corners)
    p = positions[corners]
    lo, hi = p.min(0), p.max(0)
    t = (p - lo) / np.maximum(hi - lo, 1e-6)
    colours = np.concatenate([0.1 + 0.8 * t[:, [0]], 0.15 + 0.7 * t[:, [2]], 0.9 - 0.8 * t[:, [1]],
                              np.ones((len(p), 1))], 1).astype(np.float32)
    attribute.data.foreach_set("color", colours.reshape(-1))
    mesh.color_attributes.active_color = attribute


def build_scene(width: int, height: int):
    """The procedural room: floor, two walls, a lacquered sphere, vertex-coloured props and
    scattered instances, lit by a sun and a grey World."""
    import bpy
    from mathutils import Vector

    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    ops = bpy.ops.mesh
    _add(ops.primitive_plane_add, wood_material(), size=8.0)
    back = _add(ops.primitive_plane_add, brick_material(), size=8.0, location=(0.0, 3.0, 2.0))
    back.rotation_euler = (math.pi / 2, 0.0, 0.0)
    side = _add(ops.primitive_plane_add, bumped_material(), size=8.0, location=(-3.0, 0.0, 2.0))
    side.rotation_euler = (0.0, math.pi / 2, 0.0)
    _add(ops.primitive_uv_sphere_add, lacquer_material(), radius=0.8, location=(0.4, 0.6, 0.8), segments=48,
         ring_count=24)
    bpy.ops.object.shade_smooth()
    vertex = vertex_colour_material()
    for location, size in (((-1.6, 0.8, 0.5), 1.0), ((-1.2, -0.8, 0.35), 0.7)):
        prop = _add(ops.primitive_cube_add, vertex, size=size, location=location)
        prop.rotation_euler.z = 0.4 * location[0]
        _paint_vertex_colours(prop)
    random_colours = random_colour_material()
    first = _add(ops.primitive_ico_sphere_add, random_colours, radius=0.22, subdivisions=2, location=(0, 0, 0))
    bpy.ops.object.shade_smooth()
    rng = np.random.default_rng(38)
    first.location = (1.6, -1.2, 0.22)
    for _ in range(INSTANCES - 1):  # linked duplicates: one mesh, one material, many objects
        copy = first.copy()
        x, y = rng.uniform(0.3, 2.6), rng.uniform(-1.8, 1.6)
        copy.location = (x, y, 0.22)
        scene.collection.objects.link(copy)
    sun = bpy.data.lights.new("sun", "SUN")
    sun.energy = 3.0
    sun.angle = math.radians(3.0)
    sun_obj = bpy.data.objects.new("sun", sun)
    sun_obj.rotation_mode = "QUATERNION"
    sun_obj.rotation_quaternion = Vector((0, 0, -1)).rotation_difference(Vector((0.4, 0.6, -0.7)).normalized())
    scene.collection.objects.link(sun_obj)
    world = bpy.data.worlds.new("grey")
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.3, 0.32, 0.36, 1.0)
    scene.world = world
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    camera.data.lens = 24.0
    camera.location = (3.6, -4.6, 2.4)
    direction = Vector((-0.4, 0.6, 0.8)) - camera.location
    camera.rotation_euler = direction.to_track_quat("-Z", "Y").to_euler()
    scene.collection.objects.link(camera)
    scene.camera = camera
    return scene


# ---------------------------------------------------------------------------------------------
# Baking
# ---------------------------------------------------------------------------------------------
BAKE_PASSES = (  # (bake type, image name suffix, colour image): EMIT bakes the base colour
    ("EMIT", "colour", True),
    ("ROUGHNESS", "roughness", False),
    ("NORMAL", "normal", False),
)
# Shaders that hold a material's diffuse colour, and that socket's name: the Principled's
# base colour sits under its specular layer, as a Diffuse does under the Glossy that a Mix
# Shader blends it with by a Fresnel.
_ALBEDO_SOCKETS = {"BSDF_PRINCIPLED": "Base Color", "BSDF_DIFFUSE": "Color"}


def _output(tree):
    """The material's active Material Output (the one Cycles bakes and renders)."""
    return next(n for n in tree.nodes if n.type == "OUTPUT_MATERIAL" and n.is_active_output)


def _albedo_input(tree):
    """The input socket that gives the material its diffuse colour: the first Principled or
    Diffuse BSDF reached from the Material Output's Surface through Mix and Add Shaders."""
    pending = [link.from_node for link in _output(tree).inputs["Surface"].links]
    while pending:
        node = pending.pop(0)
        if node.type in _ALBEDO_SOCKETS:
            return node.inputs[_ALBEDO_SOCKETS[node.type]]
        if node.type in ("MIX_SHADER", "ADD_SHADER"):
            pending += [link.from_node for socket in node.inputs if socket.type == "SHADER"
                        for link in socket.links]
    raise LookupError(f"material {tree.name!r}: no Principled or Diffuse BSDF under its output")


def _emit_albedo(tree):
    """Wire an Emission of the material's diffuse colour into its output for the EMIT bake;
    returns the socket the output's Surface was linked from, to put back after it."""
    nodes, links = tree.nodes, tree.links
    albedo = _albedo_input(tree)
    emission = nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 1.0
    if albedo.links:
        links.new(albedo.links[0].from_socket, emission.inputs["Color"])
    else:
        emission.inputs["Color"].default_value = albedo.default_value
    output = _output(tree)
    surface = output.inputs["Surface"].links[0].from_socket
    links.new(emission.outputs["Emission"], output.inputs["Surface"])
    return surface


def bake_to_images(scene, size: int) -> dict[str, float]:
    """Bake every mesh's material into float images with Cycles and replace each material by
    a Principled of those images. Instances become single-user first: the bake writes one
    image per material, and each instance has its own colour. Returns seconds per pass."""
    import bpy

    meshes = [o for o in scene.objects if o.type == "MESH"]
    for obj in meshes:
        obj.data = obj.data.copy()
        obj.data.materials[0] = obj.data.materials[0].copy()
        obj.data.materials[0].name = f"{obj.name} baked"
    images: dict[str, dict[str, object]] = {}
    for obj in meshes:
        images[obj.name] = {}
        tree = obj.data.materials[0].node_tree
        for kind, suffix, colour in BAKE_PASSES:
            image = bpy.data.images.new(f"{obj.name} {suffix}", size, size, alpha=False, float_buffer=True)
            image.colorspace_settings.name = "Linear Rec.709" if colour else "Non-Color"
            node = tree.nodes.new("ShaderNodeTexImage")
            node.image = image
            images[obj.name][kind] = node
    seconds: dict[str, float] = {}
    bpy.ops.object.select_all(action="DESELECT")
    for obj in meshes:
        obj.select_set(True)
    bpy.context.view_layer.objects.active = meshes[0]
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    previous_samples = scene.cycles.samples
    scene.cycles.samples = BAKE_SAMPLES
    try:
        for kind, _suffix, _colour in BAKE_PASSES:
            surfaces = {}
            for obj in meshes:
                tree = obj.data.materials[0].node_tree
                tree.nodes.active = images[obj.name][kind]
                if kind == "EMIT":
                    surfaces[obj.name] = _emit_albedo(tree)
            start = time.perf_counter()
            if kind == "NORMAL":
                bpy.ops.object.bake(type="NORMAL", normal_space="TANGENT", margin=BAKE_MARGIN, use_clear=True)
            else:
                bpy.ops.object.bake(type=kind, margin=BAKE_MARGIN, use_clear=True)
            seconds[kind] = round(time.perf_counter() - start, 2)
            for obj in meshes:  # the shaders back on the output, for the passes after
                if obj.name in surfaces:
                    tree = obj.data.materials[0].node_tree
                    tree.links.new(surfaces[obj.name], _output(tree).inputs["Surface"])
    finally:
        scene.cycles.samples = previous_samples
    for obj in meshes:
        tree = obj.data.materials[0].node_tree
        _image_material(obj.data.materials[0], {kind: tree.nodes[node.name] for kind, node in images[obj.name].items()})
    return seconds


def _image_material(material, baked: dict[str, object]) -> None:
    """Rewire ``material`` as a Principled of its baked images (the procedural nodes go)."""
    nodes, links = material.node_tree.nodes, material.node_tree.links
    kept = {node.name for node in baked.values()}  # Python wrappers are new on each access: names
    output = next(n for n in nodes if n.type == "OUTPUT_MATERIAL")
    for node in [n for n in nodes if n.type != "OUTPUT_MATERIAL" and n.name not in kept]:
        nodes.remove(node)
    bsdf = nodes.new("ShaderNodeBsdfPrincipled")
    normal_map = nodes.new("ShaderNodeNormalMap")
    links.new(baked["EMIT"].outputs["Color"], bsdf.inputs["Base Color"])
    links.new(baked["ROUGHNESS"].outputs["Color"], bsdf.inputs["Roughness"])
    links.new(baked["NORMAL"].outputs["Color"], normal_map.inputs["Color"])
    links.new(normal_map.outputs["Normal"], bsdf.inputs["Normal"])
    links.new(bsdf.outputs["BSDF"], output.inputs["Surface"])


# ---------------------------------------------------------------------------------------------
# Measurement
# ---------------------------------------------------------------------------------------------
def measure(args, addon) -> dict:
    messages = addon.blender_adapter.messages
    scene = build_scene(args.width, args.height)
    key = f"procedural_v{SCENE_VERSION}_{args.width}x{args.height}"
    results: dict[str, dict] = {}
    images: dict[str, np.ndarray] = {}
    with tempfile.TemporaryDirectory(prefix="hybrid_rt_procedural_") as temporary:
        folder = Path(temporary)
        cycles, cycles_s = cached(args.references, f"{key}_cycles{args.cycles_samples}",
                                  lambda: render_cycles(scene, args.cycles_samples, folder)[:2])
        images["cycles"] = cycles
        results["cycles"] = {"seconds": round(cycles_s, 2), "samples": args.cycles_samples}
        eevee, eevee_s, info = cached_eevee(args.references, f"{key}_eevee{args.eevee_samples}",
                                            lambda: render_eevee(scene, args.eevee_samples, folder))
        if eevee is not None:
            images["eevee"] = eevee
            results["eevee"] = {"seconds": round(eevee_s, 2), "flip_vs_cycles": flip_map(cycles, eevee)[1]}
        else:
            results["eevee"] = {"unavailable": info.get("reason", "")}
        with messages.collecting() as told:
            image, frame, seconds = render_hybrid(scene, "HYBRID", folder)
        images["hybrid"] = image
        results["hybrid"] = {"seconds": round(seconds, 2), "frame_ms": round(frame.total_ms, 1),
                             "flip_vs_cycles": flip_map(cycles, image)[1], "reported": list(told)}
        bake_s = bake_to_images(scene, args.bake_size)
        with messages.collecting() as told:
            image, frame, seconds = render_hybrid(scene, "HYBRID", folder)
        images["hybrid_baked"] = image
        results["hybrid_baked"] = {"seconds": round(seconds, 2), "frame_ms": round(frame.total_ms, 1),
                                   "bake_seconds": bake_s, "bake_size": args.bake_size,
                                   "flip_vs_cycles": flip_map(cycles, image)[1], "reported": list(told)}
    hybrid, baked = results["hybrid"]["flip_vs_cycles"], results["hybrid_baked"]["flip_vs_cycles"]
    bars = {"hybrid_within_baked": abs(hybrid - baked) <= BAKED_TOLERANCE}
    if "flip_vs_cycles" in results["eevee"]:
        bars["hybrid_at_or_below_eevee"] = hybrid <= results["eevee"]["flip_vs_cycles"]
    if args.sheet:
        tiles = [labelled(display_bytes(im), name if name == "cycles"
                          else f"{name} FLIP {results[name]['flip_vs_cycles']:.3f}") for name, im in images.items()]
        write_png(Path(args.sheet), np.concatenate(tiles, axis=1))
    return {"results": results, "bars": bars}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--width", type=int, default=DEFAULT_SIZE[0])
    parser.add_argument("--height", type=int, default=DEFAULT_SIZE[1])
    parser.add_argument("--cycles-samples", type=int, default=CYCLES_SAMPLES)
    parser.add_argument("--eevee-samples", type=int, default=EEVEE_SAMPLES)
    parser.add_argument("--bake-size", type=int, default=BAKE_SIZE)
    parser.add_argument("--references", default=None,
                        help="keep the Cycles and EEVEE images in this folder and reuse them")
    parser.add_argument("--json", default=None, help="write every number to this file")
    parser.add_argument("--sheet", default=None, help="write the four images side by side to this PNG")
    args = parser.parse_args(argv)
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon = load_addon()
    addon.register()
    start = time.perf_counter()
    try:
        numbers = measure(args, addon)
    finally:
        addon.unregister()
    numbers["seconds"] = round(time.perf_counter() - start, 1)
    print(json.dumps(numbers, indent=2))
    if args.json:
        Path(args.json).write_text(json.dumps({"source": str(REPO_ROOT), **numbers}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
