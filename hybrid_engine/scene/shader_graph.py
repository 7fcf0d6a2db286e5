# SPDX-License-Identifier: GPL-3.0-or-later
"""A material's shader node graph as plain data: what the Blender adapter reads out of a node
tree, and what the core compiles into a node program for the GPU.

Blender's node trees carry things the renderer must not see: groups, reroutes, muted nodes,
frames, UI state. The adapter resolves them as Blender does (groups flattened at any depth,
reroutes followed, a muted node replaced by its internal links) and hands over this flat
form. It knows nothing of Blender, so the compiler and its tests run without bpy, and a graph
can be built by hand in a test or a benchmark.

Naming follows Blender so that a reader can hold a graph beside the node editor:
- ``GraphNode.kind`` is the node's ``type`` (``"MATH"``, ``"TEX_NOISE"``, ``"BSDF_PRINCIPLED"``);
- ``settings`` holds the node's properties under their Python names (``operation``,
  ``blend_type``, ``data_type``, ``noise_dimensions``, ...). Enum values stay Blender's strings;
  curves and colour ramps are given as plain tuples (see the compiler for each kind's shape);
  an image is given as ``texture``, its layer in ``MaterialTable.textures``;
- ``inputs`` and a ``Link``'s ``output`` use socket *identifiers*, which are unique where
  names are not (the Mix node has three inputs named "A").

Values of unlinked inputs are constants: a float, or a tuple (a vector of 3, a colour of 4).
The split between constants and the rest is what makes an edit cheap: ``topology_key`` leaves
the constants out, so two graphs with the same key differ only in values, which is an upload
of the program's constants and never a shader compile.
"""
from __future__ import annotations

import sys
import types
from dataclasses import dataclass, field
from typing import Union

Constant = Union[float, tuple[float, ...]]
Setting = Union[str, int, float, bool, tuple]


class ShaderGraphError(ValueError):
    """A graph that cannot be compiled: a link to a later or missing node, or an output that
    is not there. The adapter builds graphs in order, so this is a bug, not an artist's
    mistake."""


@dataclass(frozen=True)
class Link:
    """The value of output socket ``output`` (an identifier) of node ``node`` (an index into
    ``ShaderGraph.nodes``)."""

    node: int
    output: str


Input = Union[Link, Constant]


@dataclass
class GraphNode:
    """One node: its Blender type, its properties, and each input as a link or a constant.
    ``name`` is the artist's node name, for messages. An input that is absent takes Blender's
    default for that socket (the compiler knows the defaults of the kinds it compiles)."""

    kind: str
    name: str = ""
    settings: dict[str, Setting] = field(default_factory=dict)
    inputs: dict[str, Input] = field(default_factory=dict)


@dataclass
class ShaderGraph:
    """A material's graph, flat and in evaluation order: every link points to an earlier node.

    ``surface`` is what the Material Output's Surface input receives (a shader socket), or a
    constant-free ``None`` when nothing is linked (Blender renders such a material black).
    ``displacement`` is the Displacement input, ``None`` when unlinked."""

    nodes: list[GraphNode] = field(default_factory=list)
    surface: Link | None = None
    displacement: Link | None = None

    def add(self, kind: str, name: str = "", settings: dict[str, Setting] | None = None,
            **inputs: Input) -> int:
        """Append a node and return its index (inputs by identifier; use ``inputs`` of the
        node for identifiers that are not Python names)."""
        self.nodes.append(GraphNode(kind, name or kind.lower(), dict(settings or {}), dict(inputs)))
        return len(self.nodes) - 1

    def validate(self) -> None:
        """Raise ``ShaderGraphError`` unless every link points to an earlier node."""
        for index, node in enumerate(self.nodes):
            for socket, value in node.inputs.items():
                if isinstance(value, Link) and not 0 <= value.node < index:
                    raise ShaderGraphError(
                        f"node {index} ({node.kind} {node.name!r}) input {socket!r} links to "
                        f"node {value.node}, which is not an earlier node")
        for label, link in (("surface", self.surface), ("displacement", self.displacement)):
            if link is not None and not 0 <= link.node < len(self.nodes):
                raise ShaderGraphError(f"{label} links to missing node {link.node}")

    def topology_key(self) -> tuple:
        """Everything but the constants: kinds, settings and links. Equal keys mean the same
        program shape, so an edit between them changes values only."""
        def input_key(value: Input) -> object:
            return ("link", value.node, value.output) if isinstance(value, Link) else "const"

        return (
            tuple((node.kind, tuple(sorted((k, repr(v)) for k, v in node.settings.items())),
                   tuple(sorted((k, input_key(v)) for k, v in node.inputs.items())))
                  for node in self.nodes),
            self.surface, self.displacement)


# The package can be imported under two names in one process (Blender's add-on,
# ``bl_ext.*.hybrid_rt``, and the top-level ``hybrid_engine`` of scripts and benchmarks). A
# graph the add-on's reader builds must be one the other name's compiler recognises
# (``isinstance(value, Link)``), so these classes are one per process: the first import's.
_SHARED_KEY = "_hybrid_rt_shader_graph_classes"
_shared = sys.modules.setdefault(_SHARED_KEY, types.ModuleType(_SHARED_KEY))
if hasattr(_shared, "Link"):
    globals().update(Link=_shared.Link, GraphNode=_shared.GraphNode, ShaderGraph=_shared.ShaderGraph,
                     ShaderGraphError=_shared.ShaderGraphError, Input=Union[_shared.Link, Constant])
else:
    _shared.Link, _shared.GraphNode, _shared.ShaderGraph, _shared.ShaderGraphError = (
        Link, GraphNode, ShaderGraph, ShaderGraphError)
