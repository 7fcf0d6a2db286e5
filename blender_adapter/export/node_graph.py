# SPDX-License-Identifier: GPL-3.0-or-later
"""A material's node tree as the core's flat ``ShaderGraph`` (hybrid_engine/scene/shader_graph.py).

The graph is read as Blender evaluates it, so that the GPU sees what Cycles and EEVEE see:

- it starts at the active Material Output (``get_output_node``) and follows the Surface and
  Displacement links backwards; only the nodes that reach the output are emitted, each after
  the nodes it reads (evaluation order);
- node groups are flattened at any depth: a Group Output's input is read inside the group, a
  Group Input's output is the group node's input outside it (its own value when unlinked);
- reroutes are followed; frames never reach a link;
- a muted node passes each output the input its ``internal_links`` name, else the output's
  default value; muted links, invalid links and links to unavailable sockets are ignored
  (the input keeps its own value), as Cycles' sync skips them;
- a node kind the core does not evaluate (``node_kinds.SUPPORTED_KINDS``) is named once to the
  artist and its outputs take their default values, so the rest of the graph still renders.

Values of unlinked inputs are constants (float, vector of 3, colour of 4); a constant that
crosses a group or muted node into a socket of another type is converted as Blender's
implicit conversions do. Settings are the node's own RNA properties (enums as strings), read
generically; what RNA holds in sub-structures is read here: Color Ramp and curve tables
baked as Cycles bakes them, an image as its layer in the material table's texture list.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...hybrid_engine.scene.node_kinds import SUPPORTED_KINDS
from ...hybrid_engine.scene.shader_graph import GraphNode, Input, Link, Setting, ShaderGraph
from . import tell
from .images import image_pixels

# The Material Output the graph starts from: the one EEVEE would use (target ALL or EEVEE,
# the active one first), as the material rows (materials.surface_node) read it.
OUTPUT_TARGET = "EEVEE"
# Cycles bakes Color Ramps and curves into RAMP_TABLE_SIZE + 1 entries, entry i at
# t = min_x + i / RAMP_TABLE_SIZE * (max_x - min_x) (intern/cycles/blender/util.h).
RAMP_TABLE_SIZE = 256
# RNA property types read as settings; pointers (images, ramps, curves, objects) are read by
# hand below, collections never.
_SETTING_TYPES = frozenset({"ENUM", "BOOLEAN", "INT", "FLOAT", "STRING"})
# Per node class (``bl_idname``), its own settings' RNA (name, type, enum flag, array length):
# walking ``bl_rna.properties`` costs more than reading the values, so once per class.
_own_properties: dict[str, tuple[tuple[str, str, bool, int], ...]] = {}
# Rec.709 luminance: Blender's colour-to-float conversion in the default colour management.
_LUMINANCE = (0.2126, 0.7152, 0.0722)


def _node_properties(node) -> tuple[tuple[str, str, bool, int], ...]:
    """The node's own settings' RNA, less what every node has (name, location, mute, ...)."""
    found = _own_properties.get(node.bl_idname)
    if found is None:
        import bpy
        base = {p.identifier for p in bpy.types.ShaderNode.bl_rna.properties}
        found = tuple((p.identifier, p.type, p.type == "ENUM" and bool(p.is_enum_flag), int(getattr(p, "array_length", 0)))
                      for p in node.bl_rna.properties if p.identifier not in base and p.type in _SETTING_TYPES)
        _own_properties[node.bl_idname] = found
    return found


@dataclass
class NodeGraphRead:
    """A material's graph and what the reader saw on the way: ``structural`` is True when
    resolving it went through a group, a muted node or an ignored link (the material rows'
    own reader does not, so only a graph without them can be represented by the rows);
    ``images`` holds the pixels that ``settings["texture"]`` indexes."""

    graph: ShaderGraph
    structural: bool = False
    images: list[np.ndarray] = field(default_factory=list)


def read_node_graph(material, images: bool = True) -> NodeGraphRead | None:
    """The ``ShaderGraph`` of ``material``'s active output, or None when it has no node tree
    or no output. With ``images`` False no pixels are read (``texture`` is then -1)."""
    tree = getattr(material, "node_tree", None)
    if tree is None:
        return None
    output = tree.get_output_node(OUTPUT_TARGET)
    if output is None:
        return None
    reader = _Reader(material.name, images)
    graph = reader.read(output)
    graph.validate()
    return NodeGraphRead(graph, reader.structural, reader.images)


class _Reader:
    """One read of one material's tree (see the module docstring for the rules)."""

    def __init__(self, owner: str, images: bool) -> None:
        self.owner = owner
        self.read_images = images
        self.graph = ShaderGraph()
        self.structural = False
        self.images: list[np.ndarray] = []
        self._image_slots: dict[int, int] = {}
        self._emitted: dict[tuple, int] = {}
        self._visiting: set[tuple] = set()
        self._links: dict[int, dict[int, object]] = {}  # tree -> to_socket -> its link

    def read(self, output) -> ShaderGraph:
        for label in ("Surface", "Displacement"):
            socket = output.inputs.get(label)
            value = self.input_value(socket, ()) if socket is not None and socket.enabled else None
            setattr(self.graph, label.lower(), value if isinstance(value, Link) else None)
        return self.graph

    # -- links ----------------------------------------------------------------------------

    def _incoming(self, socket):
        """The link that feeds input ``socket`` as Blender evaluates it, or None. One pass
        over the tree's links per tree (``socket.links`` walks them all on every call)."""
        tree = socket.id_data
        by_socket = self._links.get(tree.as_pointer())
        if by_socket is None:
            by_socket = {}
            for link in tree.links:
                by_socket.setdefault(link.to_socket.as_pointer(), []).append(link)
            self._links[tree.as_pointer()] = by_socket
        for link in by_socket.get(socket.as_pointer(), ()):
            if link.is_muted or not link.is_valid or not (link.from_socket.enabled and link.to_socket.enabled):
                self.structural = True
                continue
            return link
        return None

    def input_value(self, socket, scope: tuple) -> Input | None:
        """What input ``socket`` (of a node in group ``scope``) receives: a link to an
        emitted node, a constant in the socket's type, or None (a shader with nothing)."""
        link = self._incoming(socket)
        if link is None:
            return _constant(socket)
        return self.output_value(link.from_node, link.from_socket, scope, socket)

    def output_value(self, node, output, scope: tuple, target) -> Input | None:
        """The value of ``output`` of ``node`` as seen by input socket ``target``."""
        kind = node.type
        if kind == "REROUTE":
            link = self._incoming(node.inputs[0])
            if link is None:  # a dangling reroute: the input keeps its own value
                return _constant(target)
            return self.output_value(link.from_node, link.from_socket, scope, target)
        if kind == "GROUP_INPUT":
            self.structural = True
            group = scope[-1] if scope else None
            outer = _by_identifier(group.inputs, output.identifier) if group is not None else None
            if outer is None:
                return _constant(target)
            return _convert(self.input_value(outer, scope[:-1]), target.type)
        if node.mute:
            self.structural = True
            for internal in node.internal_links:
                if internal.to_socket.identifier == output.identifier:
                    value = self.input_value(internal.from_socket, scope)
                    return _convert(_convert(value, output.type), target.type)
            return _convert(_constant(output), target.type)
        if kind == "GROUP":
            self.structural = True
            inner = _group_output_socket(node, output.identifier)
            if inner is None:
                return _convert(_constant(output), target.type)
            value = self.input_value(inner, scope + (node,))
            return _convert(_convert(value, output.type), target.type)
        if kind not in SUPPORTED_KINDS:
            tell("%s: %s nodes are not supported; their outputs take their default values",
                 self.owner, node.bl_label)
            return _convert(_constant(output), target.type)
        index = self.emit(node, scope)
        if index is None:  # a cycle (Blender marks such links invalid; never trust it blindly)
            return _constant(target)
        return Link(index, output.identifier)

    # -- nodes ----------------------------------------------------------------------------

    def emit(self, node, scope: tuple) -> int | None:
        """The index of ``node`` (in group ``scope``) in the graph, emitted after its inputs."""
        key = tuple(g.as_pointer() for g in scope) + (node.as_pointer(),)
        if key in self._emitted:
            return self._emitted[key]
        if key in self._visiting:
            return None
        self._visiting.add(key)
        inputs: dict[str, Input] = {}
        for socket in node.inputs:
            if not socket.enabled:  # unavailable for the node's settings (the Mix node's other types)
                continue
            value = self.input_value(socket, scope)
            if value is not None and not (_implicit(node, socket) and not isinstance(value, Link)):
                inputs[socket.identifier] = value
        if node.type in ("VALUE", "RGB"):  # their value lives on the output socket
            for socket in node.outputs:
                value = _constant(socket)
                if value is not None:
                    inputs[socket.identifier] = value
        settings = self.settings(node)
        self._visiting.discard(key)
        name = "/".join([g.name for g in scope] + [node.name])
        self.graph.nodes.append(GraphNode(node.type, name, settings, inputs))
        index = len(self.graph.nodes) - 1
        self._emitted[key] = index
        return index

    def settings(self, node) -> dict[str, Setting]:
        """The node's own properties by Python name, and what its pointers hold."""
        settings: dict[str, Setting] = {name: _setting(kind, flag, length, getattr(node, name))
                                        for name, kind, flag, length in _node_properties(node)}
        image = getattr(node, "image", None) if node.type in ("TEX_IMAGE", "TEX_ENVIRONMENT") else None
        if node.type in ("TEX_IMAGE", "TEX_ENVIRONMENT"):
            settings["texture"] = self.texture(image)
            settings["alpha_mode"] = str(image.alpha_mode) if image is not None else "STRAIGHT"
        if node.type == "VALTORGB":
            settings.update(_ramp_settings(node.color_ramp))
        if node.type in _CURVE_COUNTS:
            settings.update(_curve_settings(node.mapping, node.type))
        if node.type == "TEX_COORD":
            settings["object"] = node.object.name_full if node.object is not None else ""
        return settings

    def texture(self, image) -> int:
        """The image's index in ``images`` (read once per read), -1 when it has no pixels."""
        if image is None or not self.read_images:
            return -1
        pixels = image_pixels(image)
        if pixels is None:
            return -1
        if id(pixels) not in self._image_slots:
            self._image_slots[id(pixels)] = len(self.images)
            self.images.append(pixels)
        return self._image_slots[id(pixels)]


def _implicit(node, socket) -> bool:
    """An input whose unlinked value Blender never reads: a texture's Vector (Generated or UV
    coordinates) and a shader's Normal or Tangent (the shading frame). Left out of the graph,
    so the compiler gives it Blender's implicit default, as Cycles links one in."""
    if not socket.hide_value or socket.type != "VECTOR":
        return False
    return node.type.startswith("TEX_") or socket.identifier in _IMPLICIT_NORMALS


_IMPLICIT_NORMALS = frozenset({"Normal", "Tangent", "Coat Normal"})


def _by_identifier(sockets, identifier: str):
    for socket in sockets:
        if socket.identifier == identifier:
            return socket
    return None


def _group_output_socket(group, identifier: str):
    """The input of ``group``'s active Group Output that gives its output ``identifier``."""
    tree = group.node_tree
    if tree is None:
        return None
    outputs = [n for n in tree.nodes if n.type == "GROUP_OUTPUT"]
    active = [n for n in outputs if n.is_active_output] or outputs
    return _by_identifier(active[0].inputs, identifier) if active else None


def _constant(socket) -> float | tuple[float, ...] | None:
    """A socket's own value: a float, or a tuple of floats; None for shaders (and strings)."""
    value = getattr(socket, "default_value", None)
    if value is None or isinstance(value, str):
        return None
    if hasattr(value, "__len__"):
        return tuple(float(v) for v in value)
    return float(value)


def _convert(value: Input | None, socket_type: str) -> Input | None:
    """A constant in a socket of type ``socket_type``, as Blender converts implicitly
    (colour to float: luminance; vector to float: average; float to colour: grey, alpha 1).
    Links are left to the compiler, which knows the types of the outputs it compiles."""
    if value is None or isinstance(value, Link):
        return value
    if socket_type == "SHADER":
        return None
    if isinstance(value, float):
        if socket_type == "RGBA":
            return (value, value, value, 1.0)
        if socket_type in ("VECTOR", "ROTATION"):
            return (value, value, value)
        return value
    if socket_type in ("VALUE", "INT", "BOOLEAN"):
        if len(value) == 4:
            return float(sum(w * c for w, c in zip(_LUMINANCE, value)))
        return float(sum(value) / len(value))
    if socket_type == "RGBA":
        return tuple(value[:3]) + (value[3] if len(value) == 4 else 1.0,)
    if socket_type in ("VECTOR", "ROTATION"):
        return tuple(value[:3])
    return value


def _setting(kind: str, enum_flag: bool, array_length: int, value) -> Setting:
    """One RNA property value as plain data (enum flags and arrays as tuples)."""
    if kind == "ENUM":
        return tuple(sorted(value)) if enum_flag else str(value)
    if array_length:
        convert = {"BOOLEAN": bool, "INT": int}.get(kind, float)
        return tuple(convert(v) for v in value)
    return {"BOOLEAN": bool, "INT": int, "FLOAT": float, "STRING": str}[kind](value)


# Baked tables by what they are baked from: a viewport sync reads every changed material
# again, and a table is hundreds of ``evaluate`` calls. Cleared beyond _TABLES_KEPT.
_tables: dict[tuple, tuple] = {}
_TABLES_KEPT = 512


def _baked(key: tuple, bake) -> tuple:
    table = _tables.get(key)
    if table is None:
        if len(_tables) >= _TABLES_KEPT:
            _tables.clear()
        table = _tables[key] = bake()
    return table


def _ramp_settings(ramp) -> dict[str, Setting]:
    """A Color Ramp: its stops and modes, and Cycles' table (RAMP_TABLE_SIZE + 1 RGBA entries
    of ``ColorRamp.evaluate`` at i / RAMP_TABLE_SIZE; a constant ramp is looked up without
    interpolating between entries)."""
    settings: dict[str, Setting] = {
        "color_ramp_elements": tuple((float(e.position), tuple(float(c) for c in e.color)) for e in ramp.elements),
        "color_ramp_interpolation": str(ramp.interpolation),
        "color_ramp_color_mode": str(ramp.color_mode),
        "color_ramp_hue_interpolation": str(ramp.hue_interpolation),
    }
    positions = (np.arange(RAMP_TABLE_SIZE + 1, dtype=np.float32) / np.float32(RAMP_TABLE_SIZE)).tolist()
    settings["color_ramp"] = _baked(("ramp",) + tuple(settings.values()), lambda: tuple(
        tuple(float(c) for c in ramp.evaluate(t)) for t in positions))
    return settings


# Curves per curve node that Cycles bakes (RGB Curves: R, G, B and the combined C curve).
_CURVE_COUNTS = {"CURVE_RGB": 4, "CURVE_VEC": 3, "CURVE_FLOAT": 1}


def _curve_settings(mapping, kind: str) -> dict[str, Setting]:
    """A curve node as Cycles bakes it (intern/cycles/blender/util.h): x from the first
    point's lowest to the last point's highest x over the curves used, RAMP_TABLE_SIZE + 1
    samples of ``CurveMapping.evaluate``; RGB Curves apply the combined curve first. The
    kernel reads entry (x - min_x) / (max_x - min_x), extrapolating linearly past the ends
    when the mapping's extend is EXTRAPOLATED."""
    count = _CURVE_COUNTS[kind]
    curves = list(mapping.curves)[:count]
    min_x = np.float32(min(c.points[0].location[0] for c in curves))
    max_x = np.float32(max(c.points[-1].location[0] for c in curves))
    steps = np.arange(RAMP_TABLE_SIZE + 1, dtype=np.float32) / np.float32(RAMP_TABLE_SIZE)
    positions = (min_x + steps * (max_x - min_x)).tolist()  # in float32, as Cycles computes them
    evaluate = mapping.evaluate

    def bake() -> tuple:
        mapping.initialize()  # builds the evaluation tables of a mapping never drawn
        if kind == "CURVE_RGB":
            combined = curves[3]
            return tuple(tuple(float(evaluate(c, evaluate(combined, t))) for c in curves[:3]) for t in positions)
        if kind == "CURVE_VEC":
            return tuple(tuple(float(evaluate(c, t)) for c in curves) for t in positions)
        return tuple(float(evaluate(curves[0], t)) for t in positions)

    key = (kind, mapping.extend, mapping.use_clip, mapping.clip_min_x, mapping.clip_max_x, mapping.clip_min_y,
           mapping.clip_max_y, tuple(tuple((tuple(p.location), p.handle_type) for p in c.points) for c in curves))
    return {
        "curve_table": _baked(key, bake),
        "curve_min_x": float(min_x),
        "curve_max_x": float(max_x),
        "curve_extrapolate": mapping.extend == "EXTRAPOLATED",
    }
