# SPDX-License-Identifier: GPL-3.0-or-later
"""Shader graphs compiled into node programs: the words one interpreter shader runs
(gpu_shaders/include/node_program.glsl), in the shape of Cycles' SVM.

Why a program: a shader generated per material would bake the artist's values into code,
and every edit would be a shader compile (seconds on a CPU driver, and the viewport stalls for
it). A program is data: a value edit changes the constant words, a new link or enum changes
other words, and either is an upload of a few hundred bytes; the one interpreter is compiled
once per scene shape. Where generated GLSL runs (passes/scene_upload/node_codegen.py), it is
written per program *topology* and still reads every value from these words, so a value edit
stays an upload (docs/ARCHITECTURE.md "Shader node programs").

The words (node_codes.py): one instruction per node, its inputs read from registers, inline
constants or the shading point, its outputs written to registers. Registers are reused once
the last reader of a value has run (a linear scan over the nodes in evaluation order), so a
deep graph fits the interpreter's small fixed register file; a graph that does not fit fails
here with its material's name. Only the nodes the Material Output reaches are compiled.

A shader socket carries a closure (six registers): the weighted sums of the surface's
parameters and, apart, of its Glossy lobes, so that Mix Shader and Add Shader mix closures
by mixing their sums; the interpreter makes Glossy lobes over a diffuse base a coat layer of
their own and means of the rest (node_program.glsl documents what this holds against
Cycles' true mix of closures).
"""
from __future__ import annotations

import math
import struct
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from . import node_codes as nc
from .mesh_attributes import AttributeRequests, node_key, requests_of
from .shader_graph import Constant, GraphNode, Link, ShaderGraph

VALUE, VECTOR, RGBA, SHADER = "VALUE", "VECTOR", "RGBA", "SHADER"
CLOSURE_REGISTERS = 6  # a shader value: node_program.glsl NODE_CLOSURE_REGISTERS (closure lobes)


class NodeProgramError(ValueError):
    """A graph the interpreter cannot run (more live values than its registers)."""


@dataclass(frozen=True)
class NodeSpec:
    """How one Blender node kind compiles: its opcode, its inputs in operand order
    (identifier, type, Blender's default: a constant or an ``IMPLICIT_*`` code as ``("implicit",
    code)``), its outputs in register order, and its settings (property name, encoder to an
    int word). Adding a node is one spec here and one case in node_program.glsl.

    ``family``: the define that compiles the node's case into the interpreter ("" for the
    always-present core). ``table``: words that follow the operands (a Color Ramp's or a
    curve's baked samples), made from the node's settings; the case reads them in place."""

    opcode: int
    inputs: tuple[tuple[str, str, object], ...] = ()
    outputs: tuple[tuple[str, str], ...] = ()
    settings: tuple[tuple[str, Callable[[object], int]], ...] = ()
    family: str = ""
    table: Callable[[dict], list[int]] | None = None


def _enum(codes: dict[str, int], default: str) -> Callable[[object], int]:
    def encode(value: object) -> int:
        return codes.get(str(value if value is not None else default), codes[default])
    return encode


def _float(default: float) -> Callable[[object], int]:
    """A float setting (Brick's offset, Image's box blend) as its bits."""
    def encode(value: object) -> int:
        try:
            return _float_word(float(value) if value is not None else default)
        except (TypeError, ValueError):
            return _float_word(default)
    return encode


def _flag(default: bool) -> Callable[[object], int]:
    def encode(value: object) -> int:
        return int(bool(default if value is None else value))
    return encode


def _int(default: int) -> Callable[[object], int]:
    def encode(value: object) -> int:
        try:
            return int(value) if value is not None else default
        except (TypeError, ValueError):
            return default
    return encode


def _ramp_table(settings: dict) -> list[int]:
    """Cycles' Color Ramp table (the reader's ``color_ramp``: TABLE_SIZE RGBA samples at
    i / (TABLE_SIZE - 1)); without one, Blender's default ramp (black to white, linear)."""
    table = settings.get("color_ramp")
    if table is None or len(table) != nc.TABLE_SIZE:
        t = np.arange(nc.TABLE_SIZE, dtype=np.float32) / np.float32(nc.TABLE_SIZE - 1)
        table = np.stack([t, t, t, np.ones_like(t)], -1)
    return np.asarray(table, np.float32).reshape(-1)[:nc.RAMP_TABLE_WORDS].view(np.uint32).tolist()


def _curve_table(kind: str) -> Callable[[dict], list[int]]:
    """A curve node's table (the reader's ``curve_table``: TABLE_SIZE samples over
    [curve_min_x, curve_max_x], a column per channel or axis); without one, the identity."""
    columns = nc.CURVE_TABLE_WORDS[kind] // nc.TABLE_SIZE

    def table(settings: dict) -> list[int]:
        values = settings.get("curve_table")
        if values is None or len(values) != nc.TABLE_SIZE:
            lo, hi = float(settings.get("curve_min_x", 0.0)), float(settings.get("curve_max_x", 1.0))
            t = lo + np.arange(nc.TABLE_SIZE, dtype=np.float32) / np.float32(nc.TABLE_SIZE - 1) * (hi - lo)
            values = np.repeat(t[:, None], columns, 1)
        flat = np.asarray(values, np.float32).reshape(nc.TABLE_SIZE, -1)[:, :columns]
        return np.ascontiguousarray(flat).reshape(-1).view(np.uint32).tolist()
    return table
def _component(index: int, default: tuple[float, ...]) -> Callable[[object], int]:
    """One component of a vector setting as a float word (a vector takes one word each)."""
    def encode(value: object) -> int:
        try:
            return _float_word(float(tuple(value)[index]))  # type: ignore[arg-type]
        except (TypeError, ValueError, IndexError):
            return _float_word(default[index])
    return encode


_N = ("implicit", nc.IMPLICIT_NORMAL)
_UV = ("implicit", nc.IMPLICIT_UV)
_GENERATED = ("implicit", nc.IMPLICIT_GENERATED)
_GREY = (0.8, 0.8, 0.8, 1.0)
_WHITE = (1.0, 1.0, 1.0, 1.0)
_SHADER_IN = ((SHADER, None),)
_BSDF_OUT = (("BSDF", SHADER),)

# Blender's sockets (identifiers, defaults) as Blender 5.0 declares them.
NODE_SPECS: dict[str, NodeSpec] = {
    # Value and RGB: the reader keeps their number as an input named as their output.
    "VALUE": NodeSpec(nc.OP_VALUE, (("Value", VALUE, 0.5),), (("Value", VALUE),)),
    "RGB": NodeSpec(nc.OP_VALUE, (("Color", RGBA, (0.5, 0.5, 0.5, 1.0)),), (("Color", RGBA),)),
    "TEX_COORD": NodeSpec(nc.OP_TEX_COORD, (), (("Generated", VECTOR), ("Normal", VECTOR), ("UV", VECTOR),
                                                ("Object", VECTOR), ("Camera", VECTOR), ("Window", VECTOR),
                                                ("Reflection", VECTOR))),
    "UVMAP": NodeSpec(nc.OP_UVMAP, (), (("UV", VECTOR),)),
    "NEW_GEOMETRY": NodeSpec(nc.OP_GEOMETRY, (), (("Position", VECTOR), ("Normal", VECTOR), ("Tangent", VECTOR),
                                                  ("True Normal", VECTOR), ("Incoming", VECTOR),
                                                  ("Parametric", VECTOR), ("Backfacing", VALUE))),
    "OBJECT_INFO": NodeSpec(nc.OP_OBJECT_INFO, (), (("Location", VECTOR), ("Color", RGBA), ("Alpha", VALUE),
                                                    ("Object Index", VALUE), ("Material Index", VALUE),
                                                    ("Random", VALUE))),
    "FRESNEL": NodeSpec(nc.OP_FRESNEL, (("IOR", VALUE, 1.5), ("Normal", VECTOR, _N)), (("Fac", VALUE),)),
    "LAYER_WEIGHT": NodeSpec(nc.OP_LAYER_WEIGHT, (("Blend", VALUE, 0.5), ("Normal", VECTOR, _N)),
                             (("Fresnel", VALUE), ("Facing", VALUE))),
    "LIGHT_PATH": NodeSpec(nc.OP_LIGHT_PATH, (), (("Is Camera Ray", VALUE), ("Is Shadow Ray", VALUE),
                                                  ("Ray Depth", VALUE), ("Is Reflection Ray", VALUE),
                                                  ("Is Transmission Ray", VALUE))),
    "SEPXYZ": NodeSpec(nc.OP_SEPARATE_XYZ, (("Vector", VECTOR, (0.0, 0.0, 0.0)),),
                       (("X", VALUE), ("Y", VALUE), ("Z", VALUE))),
    "COMBXYZ": NodeSpec(nc.OP_COMBINE_XYZ, (("X", VALUE, 0.0), ("Y", VALUE, 0.0), ("Z", VALUE, 0.0)),
                        (("Vector", VECTOR),)),
    "TEX_WHITE_NOISE": NodeSpec(nc.OP_TEX_WHITE_NOISE, (("Vector", VECTOR, _GENERATED), ("W", VALUE, 0.0)),
                                (("Value", VALUE), ("Color", RGBA)),
                                (("noise_dimensions", _enum(nc.WHITE_NOISE_DIMENSIONS, "3D")),)),
    "TEX_IMAGE": NodeSpec(nc.OP_TEX_IMAGE, (("Vector", VECTOR, _UV),), (("Color", RGBA), ("Alpha", VALUE)),
                          (("texture", _int(-1)),)),
    "NORMAL_MAP": NodeSpec(nc.OP_NORMAL_MAP, (("Strength", VALUE, 1.0), ("Color", RGBA, (0.5, 0.5, 1.0, 1.0))),
                           (("Normal", VECTOR),), (("space", _enum(nc.NORMAL_MAP_SPACES, "TANGENT")),)),
    # -- shading normals and bump (opcodes 60-69): the Bump's two shifted Heights are the
    # pseudo-inputs _BUMP_DX and _BUMP_DY, which the compiler links to copies of the Height's
    # sub-graph (_bump_steps); Blender's graph never names them.
    "BUMP": NodeSpec(nc.OP_BUMP, (("Strength", VALUE, 1.0), ("Distance", VALUE, 0.001), ("Filter Width", VALUE, 0.1),
                                  ("Height", VALUE, 1.0), ("Normal", VECTOR, _N), ("Height_dx", VALUE, 1.0),
                                  ("Height_dy", VALUE, 1.0)),
                     (("Normal", VECTOR),), (("invert", _flag(False)),)),
    # -- end of shading normals and bump
    "BSDF_PRINCIPLED": NodeSpec(nc.OP_BSDF_PRINCIPLED, (
        ("Base Color", RGBA, _GREY), ("Metallic", VALUE, 0.0), ("Roughness", VALUE, 0.5), ("IOR", VALUE, 1.5),
        ("Alpha", VALUE, 1.0), ("Normal", VECTOR, _N), ("Specular IOR Level", VALUE, 0.5),
        ("Transmission Weight", VALUE, 0.0), ("Emission Color", RGBA, _WHITE), ("Emission Strength", VALUE, 0.0),
    ), _BSDF_OUT),
    "BSDF_DIFFUSE": NodeSpec(nc.OP_BSDF_DIFFUSE, (("Color", RGBA, _GREY), ("Roughness", VALUE, 0.0),
                                                  ("Normal", VECTOR, _N)), _BSDF_OUT),
    "BSDF_GLOSSY": NodeSpec(nc.OP_BSDF_GLOSSY, (("Color", RGBA, _GREY), ("Roughness", VALUE, 0.5),
                                                ("Normal", VECTOR, _N)), _BSDF_OUT),
    "BSDF_GLASS": NodeSpec(nc.OP_BSDF_GLASS, (("Color", RGBA, _WHITE), ("Roughness", VALUE, 0.0),
                                              ("IOR", VALUE, 1.5), ("Normal", VECTOR, _N)), _BSDF_OUT),
    "BSDF_REFRACTION": NodeSpec(nc.OP_BSDF_REFRACTION, (("Color", RGBA, _WHITE), ("Roughness", VALUE, 0.0),
                                                        ("IOR", VALUE, 1.45), ("Normal", VECTOR, _N)), _BSDF_OUT),
    "BSDF_TRANSPARENT": NodeSpec(nc.OP_BSDF_TRANSPARENT, (("Color", RGBA, _WHITE),), _BSDF_OUT),
    "EMISSION": NodeSpec(nc.OP_EMISSION, (("Color", RGBA, _WHITE), ("Strength", VALUE, 1.0)),
                         (("Emission", SHADER),)),
    "MIX_SHADER": NodeSpec(nc.OP_MIX_SHADER, (("Fac", VALUE, 0.5), ("Shader", SHADER, None),
                                              ("Shader_001", SHADER, None)), (("Shader", SHADER),)),
    "ADD_SHADER": NodeSpec(nc.OP_ADD_SHADER, (("Shader", SHADER, None), ("Shader_001", SHADER, None)),
                           (("Shader", SHADER),)),
    # -- colour and vector (opcodes 41-79)
    **{kind: NodeSpec(opcode, inputs, outputs, settings, nc.FAMILY_COLOUR if colour else nc.FAMILY_VECTOR, table)
       for kind, (opcode, inputs, outputs, settings, colour, table) in {
        "MATH": (nc.OP_MATH, (("Value", VALUE, 0.5), ("Value_001", VALUE, 0.5), ("Value_002", VALUE, 0.5)),
                 (("Value", VALUE),), (("operation", _enum(nc.MATH_OPERATIONS, "ADD")), ("use_clamp", _int(0))),
                 False, None),
        "VECT_MATH": (nc.OP_VECTOR_MATH, (("Vector", VECTOR, (0.0, 0.0, 0.0)), ("Vector_001", VECTOR, (0.0, 0.0, 0.0)),
                                          ("Vector_002", VECTOR, (0.0, 0.0, 0.0)), ("Scale", VALUE, 1.0)),
                      (("Vector", VECTOR), ("Value", VALUE)),
                      (("operation", _enum(nc.VECTOR_MATH_OPERATIONS, "ADD")),), False, None),
        "MIX": (nc.OP_MIX, (("Factor_Float", VALUE, 0.5), ("Factor_Vector", VECTOR, (0.5, 0.5, 0.5)),
                            ("A_Float", VALUE, 0.0), ("B_Float", VALUE, 0.0), ("A_Vector", VECTOR, (0.0, 0.0, 0.0)),
                            ("B_Vector", VECTOR, (0.0, 0.0, 0.0)), ("A_Color", RGBA, (0.5, 0.5, 0.5, 1.0)),
                            ("B_Color", RGBA, (0.5, 0.5, 0.5, 1.0))),
                (("Result_Float", VALUE), ("Result_Vector", VECTOR), ("Result_Color", RGBA)),
                (("data_type", _enum(nc.MIX_DATA_TYPES, "FLOAT")), ("factor_mode", _enum(nc.MIX_FACTOR_MODES, "UNIFORM")),
                 ("blend_type", _enum(nc.MIX_BLENDS, "MIX")), ("clamp_factor", _int(1)), ("clamp_result", _int(0))),
                True, None),
        "MIX_RGB": (nc.OP_MIX_RGB, (("Fac", VALUE, 0.5), ("Color1", RGBA, (0.5, 0.5, 0.5, 1.0)),
                                    ("Color2", RGBA, (0.5, 0.5, 0.5, 1.0))), (("Color", RGBA),),
                    (("blend_type", _enum(nc.MIX_BLENDS, "MIX")), ("use_clamp", _int(0))), True, None),
        "VALTORGB": (nc.OP_COLOR_RAMP, (("Fac", VALUE, 0.5),), (("Color", RGBA), ("Alpha", VALUE)),
                     (("color_ramp_interpolation", _enum(nc.RAMP_INTERPOLATIONS, "LINEAR")),), True, _ramp_table),
        **{kind: (opcode, ((fac, VALUE, 1.0), (ident, kind_type, default)), ((out, kind_type),),
                  (("curve_min_x", _float(0.0)), ("curve_max_x", _float(1.0)),
                   ("curve_extrapolate", _int(0))), True, _curve_table(kind))
           for kind, opcode, fac, ident, kind_type, default, out in (
               ("CURVE_RGB", nc.OP_CURVE_RGB, "Fac", "Color", RGBA, (1.0, 1.0, 1.0, 1.0), "Color"),
               ("CURVE_VEC", nc.OP_CURVE_VECTOR, "Fac", "Vector", VECTOR, (0.0, 0.0, 0.0), "Vector"),
               ("CURVE_FLOAT", nc.OP_CURVE_FLOAT, "Factor", "Value", VALUE, 1.0, "Value"))},
        "HUE_SAT": (nc.OP_HUE_SAT, (("Hue", VALUE, 0.5), ("Saturation", VALUE, 1.0), ("Value", VALUE, 1.0),
                                    ("Fac", VALUE, 1.0), ("Color", RGBA, _GREY)), (("Color", RGBA),), (), True, None),
        "INVERT": (nc.OP_INVERT, (("Fac", VALUE, 1.0), ("Color", RGBA, (0.0, 0.0, 0.0, 1.0))), (("Color", RGBA),), (),
                   True, None),
        "GAMMA": (nc.OP_GAMMA, (("Color", RGBA, _WHITE), ("Gamma", VALUE, 1.0)), (("Color", RGBA),), (), True, None),
        "BRIGHTCONTRAST": (nc.OP_BRIGHT_CONTRAST, (("Color", RGBA, _WHITE), ("Bright", VALUE, 0.0),
                                                   ("Contrast", VALUE, 0.0)), (("Color", RGBA),), (), True, None),
        "MAP_RANGE": (nc.OP_MAP_RANGE, (("Value", VALUE, 1.0), ("From Min", VALUE, 0.0), ("From Max", VALUE, 1.0),
                                        ("To Min", VALUE, 0.0), ("To Max", VALUE, 1.0), ("Steps", VALUE, 4.0),
                                        ("Vector", VECTOR, (0.0, 0.0, 0.0)), ("From_Min_FLOAT3", VECTOR, (0.0, 0.0, 0.0)),
                                        ("From_Max_FLOAT3", VECTOR, (1.0, 1.0, 1.0)),
                                        ("To_Min_FLOAT3", VECTOR, (0.0, 0.0, 0.0)),
                                        ("To_Max_FLOAT3", VECTOR, (1.0, 1.0, 1.0)),
                                        ("Steps_FLOAT3", VECTOR, (4.0, 4.0, 4.0))),
                      (("Result", VALUE), ("Vector", VECTOR)),
                      (("data_type", _enum(nc.MAP_RANGE_DATA_TYPES, "FLOAT")),
                       ("interpolation_type", _enum(nc.MAP_RANGE_INTERPOLATIONS, "LINEAR")), ("clamp", _int(1))),
                      False, None),
        "CLAMP": (nc.OP_CLAMP, (("Value", VALUE, 1.0), ("Min", VALUE, 0.0), ("Max", VALUE, 1.0)),
                  (("Result", VALUE),), (("clamp_type", _enum(nc.CLAMP_TYPES, "MINMAX")),), False, None),
        "SEPARATE_COLOR": (nc.OP_SEPARATE_COLOR, (("Color", RGBA, _GREY),),
                           (("Red", VALUE), ("Green", VALUE), ("Blue", VALUE)),
                           (("mode", _enum(nc.COLOR_MODES, "RGB")),), True, None),
        "COMBINE_COLOR": (nc.OP_COMBINE_COLOR, (("Red", VALUE, 0.0), ("Green", VALUE, 0.0), ("Blue", VALUE, 0.0)),
                          (("Color", RGBA),), (("mode", _enum(nc.COLOR_MODES, "RGB")),), True, None),
        "MAPPING": (nc.OP_MAPPING, (("Vector", VECTOR, (0.0, 0.0, 0.0)), ("Location", VECTOR, (0.0, 0.0, 0.0)),
                                    ("Rotation", VECTOR, (0.0, 0.0, 0.0)), ("Scale", VECTOR, (1.0, 1.0, 1.0))),
                    (("Vector", VECTOR),), (("vector_type", _enum(nc.MAPPING_TYPES, "POINT")),), False, None),
        "VECTOR_ROTATE": (nc.OP_VECTOR_ROTATE, (("Vector", VECTOR, (0.0, 0.0, 0.0)), ("Center", VECTOR, (0.0, 0.0, 0.0)),
                                                ("Axis", VECTOR, (0.0, 0.0, 1.0)), ("Angle", VALUE, 0.0),
                                                ("Rotation", VECTOR, (0.0, 0.0, 0.0))),
                          (("Vector", VECTOR),), (("rotation_type", _enum(nc.ROTATION_TYPES, "AXIS_ANGLE")),
                                                  ("invert", _int(0))), False, None),
    }.items()},
    # -- world (the World's Background graph: hybrid_engine/passes/lighting/world_bake.py)
    "BACKGROUND": NodeSpec(nc.OP_BACKGROUND, (("Color", RGBA, (0.05, 0.05, 0.05, 1.0)), ("Strength", VALUE, 1.0)),
                           (("Background", SHADER),)),
    "TEX_ENVIRONMENT": NodeSpec(nc.OP_TEX_ENVIRONMENT, (("Vector", VECTOR, _GENERATED),), (("Color", RGBA),),
                                (("texture", _int(-1)),
                                 ("projection", _enum(nc.ENVIRONMENT_PROJECTIONS, "EQUIRECTANGULAR")))),
    "TEX_SKY": NodeSpec(nc.OP_TEX_SKY, (("Vector", VECTOR, _GENERATED),), (("Color", RGBA),),
                        (("sky_type", _enum(nc.SKY_TYPES, "MULTIPLE_SCATTERING")),
                         ("sun_direction", _component(0, (0.0, 0.0, 1.0))),
                         ("sun_direction", _component(1, (0.0, 0.0, 1.0))),
                         ("sun_direction", _component(2, (0.0, 0.0, 1.0))),
                         ("turbidity", _float(2.2)), ("ground_albedo", _float(0.3)),
                         ("sun_elevation", _float(math.radians(15.0))), ("sun_rotation", _float(0.0)),
                         ("altitude", _float(100.0)), ("air_density", _float(1.0)),
                         ("aerosol_density", _float(1.0)), ("ozone_density", _float(1.0)),
                         # the first row of its transmittance table (world_bake.py sets it)
                         ("sky_table_row", _int(0)),
                         # Hosek-Wilkie's parameters for its sun (sky_hosek.py; world_bake.py sets them)
                         *(("hosek_state", _component(i, (0.0,) * 30)) for i in range(30)))),
}
# -- textures (round 2): Blender 5.0's sockets; an unlinked Vector is Generated (Image: UV).
_TEX_OUT = (("Color", RGBA), ("Fac", VALUE))
NODE_SPECS.update({
    "TEX_NOISE": NodeSpec(nc.OP_TEX_NOISE, (
        ("Vector", VECTOR, _GENERATED), ("W", VALUE, 0.0), ("Scale", VALUE, 5.0), ("Detail", VALUE, 2.0),
        ("Roughness", VALUE, 0.5), ("Lacunarity", VALUE, 2.0), ("Offset", VALUE, 0.0), ("Gain", VALUE, 1.0),
        ("Distortion", VALUE, 0.0)), (("Fac", VALUE), ("Color", RGBA)),
        (("noise_dimensions", _enum(nc.NOISE_DIMENSIONS, "3D")), ("noise_type", _enum(nc.NOISE_TYPES, "FBM")),
         ("normalize", _flag(True)))),
    "TEX_WAVE": NodeSpec(nc.OP_TEX_WAVE, (
        ("Vector", VECTOR, _GENERATED), ("Scale", VALUE, 5.0), ("Distortion", VALUE, 0.0), ("Detail", VALUE, 2.0),
        ("Detail Scale", VALUE, 1.0), ("Detail Roughness", VALUE, 0.5), ("Phase Offset", VALUE, 0.0)), _TEX_OUT,
        (("wave_type", _enum(nc.WAVE_TYPES, "BANDS")), ("bands_direction", _enum(nc.WAVE_BANDS_DIRECTIONS, "X")),
         ("rings_direction", _enum(nc.WAVE_RINGS_DIRECTIONS, "X")), ("wave_profile", _enum(nc.WAVE_PROFILES, "SIN")))),
    "TEX_VORONOI": NodeSpec(nc.OP_TEX_VORONOI, (
        ("Vector", VECTOR, _GENERATED), ("W", VALUE, 0.0), ("Scale", VALUE, 5.0), ("Detail", VALUE, 0.0),
        ("Roughness", VALUE, 0.5), ("Lacunarity", VALUE, 2.0), ("Smoothness", VALUE, 1.0), ("Exponent", VALUE, 0.5),
        ("Randomness", VALUE, 1.0)),
        (("Distance", VALUE), ("Color", RGBA), ("Position", VECTOR), ("W", VALUE), ("Radius", VALUE)),
        (("voronoi_dimensions", _enum(nc.VORONOI_DIMENSIONS, "3D")), ("feature", _enum(nc.VORONOI_FEATURES, "F1")),
         ("distance", _enum(nc.VORONOI_METRICS, "EUCLIDEAN")), ("normalize", _flag(False)))),
    "TEX_CHECKER": NodeSpec(nc.OP_TEX_CHECKER, (
        ("Vector", VECTOR, _GENERATED), ("Color1", RGBA, _GREY), ("Color2", RGBA, (0.2, 0.2, 0.2, 1.0)),
        ("Scale", VALUE, 5.0)), _TEX_OUT),
    "TEX_BRICK": NodeSpec(nc.OP_TEX_BRICK, (
        ("Vector", VECTOR, _GENERATED), ("Color1", RGBA, _GREY), ("Color2", RGBA, (0.2, 0.2, 0.2, 1.0)),
        ("Mortar", RGBA, (0.0, 0.0, 0.0, 1.0)), ("Scale", VALUE, 5.0), ("Mortar Size", VALUE, 0.02),
        ("Mortar Smooth", VALUE, 0.1), ("Bias", VALUE, 0.0), ("Brick Width", VALUE, 0.5), ("Row Height", VALUE, 0.25)),
        _TEX_OUT, (("offset", _float(0.5)), ("offset_frequency", _int(2)), ("squash", _float(1.0)),
                   ("squash_frequency", _int(2)))),
    "TEX_GRADIENT": NodeSpec(nc.OP_TEX_GRADIENT, (("Vector", VECTOR, _GENERATED),), _TEX_OUT,
                             (("gradient_type", _enum(nc.GRADIENT_TYPES, "LINEAR")),)),
    "TEX_MAGIC": NodeSpec(nc.OP_TEX_MAGIC, (("Vector", VECTOR, _GENERATED), ("Scale", VALUE, 5.0),
                                            ("Distortion", VALUE, 1.0)), _TEX_OUT,
                          (("turbulence_depth", _int(2)),)),
    # The Image Texture's mapping settings follow the layer (include/nodes/tex_image_mapping.glsl).
    "TEX_IMAGE": NodeSpec(nc.OP_TEX_IMAGE, (("Vector", VECTOR, _UV),), (("Color", RGBA), ("Alpha", VALUE)),
                          (("texture", _int(-1)), ("projection", _enum(nc.IMAGE_PROJECTIONS, "FLAT")),
                           ("extension", _enum(nc.IMAGE_EXTENSIONS, "REPEAT")),
                           ("interpolation", _enum(nc.IMAGE_INTERPOLATIONS, "Linear")),
                           ("projection_blend", _float(0.0)))),
})
# -- attributes (opcodes 70-79): Color Attribute and Attribute read one slot of the scene's
# attribute store (mesh_attributes.py). Their settings are the slot the table gives the node's
# attribute (``compile_table``), not the artist's name: the interpreter reads by slot.
_ATTRIBUTE_SETTINGS = (("attribute_source", _int(0)), ("attribute_slot", _int(-1)))
NODE_SPECS["VERTEX_COLOR"] = NodeSpec(nc.OP_ATTRIBUTE, (), (("Color", RGBA), ("Vector", VECTOR), ("Fac", VALUE),
                                                            ("Alpha", VALUE)), _ATTRIBUTE_SETTINGS,
                                      nc.FAMILY_ATTRIBUTES)
NODE_SPECS["ATTRIBUTE"] = NODE_SPECS["VERTEX_COLOR"]
# -- end of attributes
# Other names Blender has used for the same nodes.
NODE_SPECS["GEOMETRY"] = NODE_SPECS["NEW_GEOMETRY"]
NODE_SPECS["SEPARATE_XYZ"] = NODE_SPECS["SEPXYZ"]
NODE_SPECS["COMBINE_XYZ"] = NODE_SPECS["COMBXYZ"]
NODE_SPECS["BSDF_ANISOTROPIC"] = NODE_SPECS["BSDF_GLOSSY"]

_OUTPUT_SPEC = NodeSpec(nc.OP_OUTPUT, (("Surface", SHADER, None),))
# The Bump's shifted evaluations (Cycles' SVM compiles a Bump's Height sub-graph three times,
# at the shading point and at the points one Filter Width along dP/dx and dP/dy): the offset
# instruction moves the interpreter's shading point, the copies that follow read it.
_BUMP_DX, _BUMP_DY = "Height_dx", "Height_dy"
_BUMP_OFFSET_SPEC = NodeSpec(nc.OP_BUMP_OFFSET, (("Filter Width", VALUE, 0.1),), (), (("axis", _int(0)),))


def _upstream(graph: ShaderGraph, start: int) -> list[int]:
    """``start`` and every node it reads, in evaluation order."""
    needed: set[int] = set()
    stack = [start]
    while stack:
        index = stack.pop()
        if index not in needed:
            needed.add(index)
            stack.extend(v.node for v in graph.nodes[index].inputs.values() if isinstance(v, Link))
    return sorted(needed)


def _bump_steps(graph: ShaderGraph, order: list[int]) -> tuple[list[tuple[int, NodeSpec, GraphNode]], dict[int, str]]:
    """The instructions of ``order`` with each Bump's shifted Height evaluations before it:
    per axis an offset instruction and a copy of the Height's sub-graph (fresh ids from
    ``len(graph.nodes)`` on, so the copies get registers of their own), then an offset back.
    The copies run the whole sub-graph, constants included: the interpreter cannot tell which
    node reads the shading point, and a Value node costs one word. A Bump inside a Height
    sub-graph is copied with its own heights unshifted (its normal unbent there): its shifted
    copies would move the outer copy's shading point. Returns the steps and each id's kind."""
    compiled = set(order)
    kind_of = {i: graph.nodes[i].kind for i in order}
    steps: list[tuple[int, NodeSpec, GraphNode]] = []
    next_id = len(graph.nodes)

    def copy(node: GraphNode, ids: dict[int, int]) -> GraphNode:
        inputs = {k: Link(ids[v.node], v.output) if isinstance(v, Link) and v.node in ids else v
                  for k, v in node.inputs.items()}
        if NODE_SPECS[node.kind].opcode == nc.OP_BUMP and "Height" in inputs:
            inputs[_BUMP_DX] = inputs[_BUMP_DY] = inputs["Height"]
        return GraphNode(node.kind, node.name, node.settings, inputs)

    for index in order:
        node = graph.nodes[index]
        spec = NODE_SPECS[node.kind]
        if spec.opcode == nc.OP_BUMP:
            height = node.inputs.get("Height")
            shifted: dict[str, object] = {}
            if isinstance(height, Link) and height.node in compiled:
                width = {"Filter Width": node.inputs["Filter Width"]} if "Filter Width" in node.inputs else {}
                for axis, ident in ((nc.BUMP_AXIS_X, _BUMP_DX), (nc.BUMP_AXIS_Y, _BUMP_DY)):
                    steps.append((-1, _BUMP_OFFSET_SPEC, GraphNode("BUMP_OFFSET", node.name, {"axis": axis}, width)))
                    ids: dict[int, int] = {}
                    for j in (j for j in _upstream(graph, height.node) if j in compiled):
                        ids[j] = next_id
                        kind_of[next_id] = graph.nodes[j].kind
                        next_id += 1
                        steps.append((ids[j], NODE_SPECS[graph.nodes[j].kind], copy(graph.nodes[j], ids)))
                    shifted[ident] = Link(ids[height.node], height.output)
                steps.append((-1, _BUMP_OFFSET_SPEC, GraphNode("BUMP_OFFSET", node.name, {"axis": nc.BUMP_AXIS_NONE})))
            elif height is not None:
                shifted = {_BUMP_DX: height, _BUMP_DY: height}  # an unlinked Height: no slope
            node = GraphNode(node.kind, node.name, node.settings, {**node.inputs, **shifted})
        steps.append((index, spec, node))
    return steps, kind_of


def _float_word(value: float) -> int:
    value = float(value)
    return struct.unpack("<I", struct.pack("<f", value if math.isfinite(value) else 0.0))[0]


def _constant_words(value: Constant | None, kind: str) -> list[int]:
    """An inline constant operand of socket type ``kind`` (Blender's conversion applied when
    the value is of another shape)."""
    if kind == SHADER:
        return [nc.CONSTANT | 4, *([_float_word(0.0)] * 4)]  # no closure: nothing, weight 0
    values = tuple(value) if isinstance(value, (tuple, list)) else (float(value if value is not None else 0.0),)
    if kind == VALUE:
        if len(values) == 4:  # a colour: its luminance
            values = (0.2126 * values[0] + 0.7152 * values[1] + 0.0722 * values[2],)
        elif len(values) == 3:  # a vector: its mean
            values = (sum(values) / 3.0,)
        values = values[:1]
    elif len(values) == 1:
        values = values * 3
    values = values[:4]
    return [nc.CONSTANT | len(values), *(_float_word(v) for v in values)]


def _conversion(produced: str, wanted: str) -> int:
    if produced == wanted or {produced, wanted} == {VECTOR, RGBA}:
        return nc.CONVERT_NONE
    if produced == VALUE:
        return nc.CONVERT_SPLAT
    return nc.CONVERT_GRAY if produced == RGBA else nc.CONVERT_AVERAGE


@dataclass
class NodeProgram:
    """One material's program: its words, the registers it needs at most, and the nodes it
    left out (kinds the interpreter lacks: each reads as its consumers' defaults)."""

    words: np.ndarray  # uint32
    registers: int
    unsupported: list[str] = field(default_factory=list)
    families: set[str] = field(default_factory=set)  # the defines its nodes' cases need
    kinds: frozenset[str] = frozenset()  # the kinds compiled


def _reachable(graph: ShaderGraph) -> list[int]:
    """The nodes the surface depends on, in evaluation order."""
    needed: set[int] = set()
    stack = [graph.surface.node] if graph.surface is not None else []
    while stack:
        index = stack.pop()
        if index in needed:
            continue
        needed.add(index)
        stack.extend(v.node for v in graph.nodes[index].inputs.values() if isinstance(v, Link))
    return sorted(needed)


def compile_graph(graph: ShaderGraph, name: str = "material", registers: int = nc.REGISTERS,
                  attributes: AttributeRequests | None = None) -> NodeProgram:
    """The program of ``graph`` (a material's; ``name`` for messages). Raises
    NodeProgramError when its live values exceed ``registers`` at some node. ``attributes``:
    the scene's attribute slots (``graph_requests``; the graph's own when None)."""
    if attributes is None:
        attributes = graph_requests([graph])
    graph.validate()
    order = [i for i in _reachable(graph) if graph.nodes[i].kind in NODE_SPECS]
    unsupported = sorted({graph.nodes[i].kind for i in _reachable(graph)} - set(NODE_SPECS))
    steps, kind_of = _bump_steps(graph, order)
    compiled = set(kind_of)

    def producer(value: object, wanted: str) -> tuple[Link, str] | None:
        """The link and the type it carries when ``value`` links a compiled output that
        can feed a socket of type ``wanted``."""
        if not isinstance(value, Link) or value.node not in compiled:
            return None
        outputs = dict(NODE_SPECS[kind_of[value.node]].outputs)
        produced = outputs.get(value.output)
        if produced is None or (produced == SHADER) != (wanted == SHADER):
            return None  # a missing socket, or a shader into a value socket: Blender's invalid link
        return value, produced

    surface = {"Surface": graph.surface} if graph.surface is not None else {}
    steps.append((-1, _OUTPUT_SPEC, type("Out", (), {"inputs": surface, "settings": {}})()))
    last_read: dict[tuple[int, str], int] = {}
    for step, (_, spec, node) in enumerate(steps):
        for ident, kind, _default in spec.inputs:
            found = producer(node.inputs.get(ident), kind)
            if found is not None:
                last_read[(found[0].node, found[0].output)] = step

    free = list(range(registers))
    live: dict[tuple[int, str], list[int]] = {}
    peak = 0
    words: list[int] = []
    for step, (index, spec, node) in enumerate(steps):
        operands: list[int] = []
        for ident, kind, default in spec.inputs:
            value = node.inputs.get(ident)
            found = producer(value, kind)
            width = CLOSURE_REGISTERS if kind == SHADER else 1
            if found is not None:
                convert = _conversion(found[1], kind)
                operands += [nc.REGISTER | (convert << 16) | r for r in live[(found[0].node, found[0].output)]]
            elif isinstance(default, tuple) and default and default[0] == "implicit" and not (
                    value is not None and not isinstance(value, Link)):
                operands.append(nc.IMPLICIT | default[1])
            else:
                constant = value if value is not None and not isinstance(value, Link) else default
                if spec.opcode == nc.OP_VALUE and value is None:  # a hand-built graph's setting
                    constant = node.settings.get("value", constant)
                for _ in range(width):
                    operands += _constant_words(constant, kind)
        # Registers whose last reader is this node are free for its outputs (the interpreter
        # reads every input before it writes an output).
        for key in [k for k, last in last_read.items() if last == step and k in live]:
            free.extend(live.pop(key))
        free.sort()
        outputs: list[int] = []
        for ident, kind in spec.outputs:
            width = CLOSURE_REGISTERS if kind == SHADER else 1
            if (index, ident) not in last_read:
                outputs += [nc.NO_REGISTER] * width
                continue
            if len(free) < width:
                raise NodeProgramError(
                    f"{name}: the node graph holds more than {registers} values at once at node "
                    f"{node.name!r} ({kind_of.get(index, '?')}); the interpreter has {registers} registers "
                    f"(a shader value takes {CLOSURE_REGISTERS}): simplify the graph")
            taken, free = free[:width], free[width:]
            live[(index, ident)] = taken
            outputs += taken
        peak = max(peak, registers - len(free))
        node_settings = node.settings
        key = node_key(node.kind, node_settings) if index >= 0 else None  # a Bump's Height copies too
        if key is not None:
            source, slot = attributes.slot(key)
            node_settings = {**node_settings, "attribute_source": source, "attribute_slot": slot}
        settings = [spec_encode(node_settings.get(prop)) & 0xFFFFFFFF for prop, spec_encode in spec.settings]
        count = sum(CLOSURE_REGISTERS if kind == SHADER else 1 for _, kind, _ in spec.inputs)
        header = spec.opcode | (len(outputs) << 8) | (len(settings) << 16) | (count << 24)
        words += [header, *outputs, *settings, *operands]
        if spec.table is not None:
            words += spec.table(node.settings)
    kinds = frozenset(graph.nodes[i].kind for i in order)
    families = ({NODE_SPECS[kind].family for kind in kinds} - {""}) | {
        nc.TEXTURE_FAMILIES[kind] for kind in kinds if kind in nc.TEXTURE_FAMILIES}
    return NodeProgram(np.array(words, np.uint32), peak, unsupported, families, kinds)


# The word before each program in a table: the index of the generated function of its
# topology (passes/scene_upload/node_codegen.py), this value where the interpreter runs it.
DISPATCH_NONE = 0xFFFFFFFF


@dataclass
class ProgramTable:
    """Every material's program in one word array: ``offsets[m]`` is where material m's
    program starts (``Material.textures2.w``), -1 for a material without a graph. Each
    program follows one dispatch word (``DISPATCH_NONE`` until a generated function is
    given it), so the words from ``offsets[m]`` on are exactly ``compile_graph``'s."""

    words: np.ndarray  # uint32
    offsets: np.ndarray  # int32 per material
    programs: list[NodeProgram | None]
    attributes: AttributeRequests = AttributeRequests()  # the slots the programs read

    @property
    def empty(self) -> bool:
        return not (self.offsets >= 0).any()

    @property
    def families(self) -> set[str]:
        """The interpreter's family defines that some program needs (NodeSpec.family and
        node_codes.TEXTURE_FAMILIES): a family's cases compile only where a program uses it."""
        return set().union(*(p.families for p in self.programs if p is not None))


def compile_table(graphs: Sequence[ShaderGraph | None] | None, count: int,
                  names: Sequence[str] | None = None) -> ProgramTable:
    """Pack the programs of ``graphs`` (one entry or None per material of ``count``)."""
    offsets = np.full(count, -1, np.int32)
    programs: list[NodeProgram | None] = [None] * count
    attributes = graph_requests(graphs or ())
    chunks: list[np.ndarray] = []
    at = 0
    for m, graph in enumerate(graphs or ()):
        if graph is None:
            continue
        program = compile_graph(graph, names[m] if names else f"material {m}", attributes=attributes)
        programs[m] = program
        offsets[m] = at + 1
        chunks.append(np.array([DISPATCH_NONE], np.uint32))
        chunks.append(program.words)
        at += 1 + len(program.words)
    words = np.concatenate(chunks).astype(np.uint32) if chunks else np.zeros(0, np.uint32)
    return ProgramTable(words, offsets, programs, attributes)


def graph_requests(graphs: Sequence[ShaderGraph | None]) -> AttributeRequests:
    """The attributes the surfaces of ``graphs`` read (only nodes the Material Output
    reaches): what the meshes and instances must carry for them (mesh_attributes.py)."""
    return requests_of(node_key(graph.nodes[i].kind, graph.nodes[i].settings)
                       for graph in graphs if graph is not None for i in _reachable(graph))


def _constant_input(graph: ShaderGraph, node_index: int, ident: str, default: object) -> object:
    """An input's value when it is a constant or a Value/RGB node, else None."""
    value = graph.nodes[node_index].inputs.get(ident, default)
    if isinstance(value, Link):
        source = graph.nodes[value.node]
        if source.kind not in ("VALUE", "RGB"):
            return None
        return source.inputs.get("Value" if source.kind == "VALUE" else "Color", source.settings.get("value"))
    return value


def row_estimate(graph: ShaderGraph) -> dict:
    """The closure as far as the host can tell without a shading point, for what reads a
    material's fixed row and not its program: the cube faces leaving refractive surfaces out
    (transmission), the emitter table's power (emission) and the cube march's thickness
    rule. Shader nodes with constant inputs fold exactly; an unknown factor counts as 0.5,
    an unknown colour as Blender's default. Returns transmission, emission (rgb) and ior."""
    def fold(link: Link | None) -> tuple[float, np.ndarray, float, float]:
        if link is None or link.node >= len(graph.nodes):
            return 0.0, np.zeros(3), 1.5, 0.0
        node = graph.nodes[link.node]
        spec = NODE_SPECS.get(node.kind)
        if spec is None:
            return 0.0, np.zeros(3), 1.5, 0.0

        def const(ident: str, fallback):
            value = _constant_input(graph, link.node, ident, dict((i, d) for i, _, d in spec.inputs).get(ident))
            return fallback if value is None or isinstance(value, tuple) and value[:1] == ("implicit",) else value

        def rgb(value) -> np.ndarray:
            v = np.asarray(value, np.float64).reshape(-1)
            return np.resize(v, 3)[:3] if len(v) else np.zeros(3)

        if node.kind in ("MIX_SHADER", "ADD_SHADER"):
            a = node.inputs.get("Shader")
            b = node.inputs.get("Shader_001")
            fa = fold(a if isinstance(a, Link) else None)
            fb = fold(b if isinstance(b, Link) else None)
            fac = 1.0 if node.kind == "ADD_SHADER" else min(max(float(np.mean(rgb(const("Fac", 0.5)))), 0.0), 1.0)
            wa, wb = (1.0, 1.0) if node.kind == "ADD_SHADER" else (1.0 - fac, fac)
            weight = wa * fa[3] + wb * fb[3]
            trans = (wa * fa[3] * fa[0] + wb * fb[3] * fb[0]) / weight if weight > 0 else 0.0
            ior = (wa * fa[3] * fa[2] + wb * fb[3] * fb[2]) / weight if weight > 0 else 1.5
            return trans, wa * fa[1] + wb * fb[1], ior, min(weight, 1.0)
        if node.kind == "EMISSION":
            return 0.0, rgb(const("Color", _WHITE)) * float(np.mean(rgb(const("Strength", 1.0)))), 1.5, 0.0
        if node.kind == "BSDF_PRINCIPLED":
            metallic = float(np.mean(rgb(const("Metallic", 0.0))))
            trans = float(np.mean(rgb(const("Transmission Weight", 0.0)))) * (1.0 - metallic)
            emission = rgb(const("Emission Color", _WHITE)) * float(np.mean(rgb(const("Emission Strength", 0.0))))
            return trans, emission, float(np.mean(rgb(const("IOR", 1.5)))), 1.0
        if node.kind in ("BSDF_GLASS", "BSDF_REFRACTION"):
            return 1.0, np.zeros(3), float(np.mean(rgb(const("IOR", 1.5)))), 1.0
        if node.kind == "BSDF_TRANSPARENT":
            return 0.0, np.zeros(3), 1.5, 0.0
        return 0.0, np.zeros(3), 1.5, 1.0

    trans, emission, ior, _weight = fold(graph.surface)
    emission = np.where(np.isfinite(emission), np.maximum(emission, 0.0), 0.0)
    return {"transmission": float(min(max(trans, 0.0), 1.0)), "emission": tuple(float(e) for e in emission),
            "ior": float(max(ior if math.isfinite(ior) else 1.5, 1.0))}
