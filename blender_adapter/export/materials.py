# SPDX-License-Identifier: GPL-3.0-or-later
"""Materials: Blender's Principled BSDF (and the images linked to it) as rows of the
renderer's material table (hybrid_engine/scene/materials.py holds the mapping)."""
from __future__ import annotations

import numpy as np

from ...hybrid_engine.scene.closure_alpha import has_closure_alpha
from ...hybrid_engine.scene.materials import DEFAULT_THICKNESS, principled_to_params
from ...hybrid_engine.scene.data import MaterialTable
from ...hybrid_engine.scene.node_program import NODE_SPECS
from . import tell
from .alpha import split_transparent, surface_coverage
from .graph_rows import rows_hold, stand_in_inputs, table_with_graphs
from .images import image_pixels
from .node_graph import read_node_graph

def socket_value(node, name: str, default):
    """Default value of an input socket (links are not followed; colour sockets linked to an
    image go through ``_color_input``)."""
    socket = node.inputs.get(name)
    if socket is None or not hasattr(socket, "default_value"):
        return default
    value = socket.default_value
    return tuple(value) if hasattr(value, "__len__") else float(value)


def _linked_node(socket):
    """The node feeding ``socket`` (reroutes skipped), or None when unlinked or muted."""
    while socket is not None and socket.is_linked:
        link = socket.links[0]
        if link.is_muted:
            return None, None
        node = link.from_node
        if node.type != "REROUTE":
            return node, link.from_socket
        socket = node.inputs[0]
    return None, None


def _image_node(node, from_socket, owner: str):
    """``node`` when it is an Image Texture whose Color output is used, else None; warns
    about the node settings that are not reproduced."""
    if node is None or node.type != "TEX_IMAGE" or node.mute or from_socket.name != "Color":
        return None
    name = node.image.name_full if node.image is not None else "<none>"
    if node.extension != "REPEAT":
        tell("%s: image texture %r uses %s extension; it is "
                   "sampled with REPEAT", owner, name, node.extension)
    if node.projection != "FLAT":
        tell("%s: image texture %r uses %s projection; it "
                   "is sampled as FLAT", owner, name, node.projection)
    vector, _ = _linked_node(node.inputs.get("Vector"))
    if vector is not None and not (vector.type == "UVMAP" and not vector.uv_map) and vector.type != "TEX_COORD":
        tell("%s: the vector input of image texture %r is "
                   "ignored; the active render UV map is used", owner, name)
    return node


def _sockets(collection, *identifiers: str):
    """Sockets by identifier (the Mix node has several inputs named "A", one per type)."""
    by_id = {socket.identifier: socket for socket in collection}
    return tuple(by_id.get(i) for i in identifiers)


def _mix_inputs(node):
    """(factor socket, A socket, B socket) of a colour Multiply mix, else None."""
    if node.type == "MIX" and node.data_type == "RGBA" and node.blend_type == "MULTIPLY":
        sockets = _sockets(node.inputs, "Factor_Float", "A_Color", "B_Color")
    elif node.type == "MIX_RGB" and node.blend_type == "MULTIPLY":
        sockets = _sockets(node.inputs, "Fac", "Color1", "Color2")
    else:
        return None
    return sockets if all(s is not None for s in sockets) else None


def _color_input(node, name: str, default, owner: str):
    """(colour factor, image or None, the socket's own colour) of a colour input socket.

    Unlinked: its value and no image. Linked to an Image Texture's Color (directly or
    through reroutes): factor 1, since Blender then ignores the socket's value. Linked to a
    Multiply mix of an image and a constant colour c with factor f (Blender: A (1 - f + f B)):
    the image in A gives factor 1 - f + f c; in B only f = 1 is a product (factor c). Other
    links, and images without pixels, fall back to the socket's own value with a warning.
    """
    socket = node.inputs.get(name) if node is not None else None
    if socket is None or not hasattr(socket, "default_value"):
        return default, None, default
    own = tuple(socket.default_value)[:3]
    source, from_socket = _linked_node(socket)
    if source is None:
        return own, None, own
    factor, image_node = (1.0, 1.0, 1.0), _image_node(source, from_socket, owner)
    mix = _mix_inputs(source) if image_node is None and not source.mute else None
    if mix is not None:
        fac_socket, a, b = mix
        (a_node, a_from), (b_node, b_from) = _linked_node(a), _linked_node(b)
        f = float(fac_socket.default_value)
        if getattr(source, "clamp_factor", True) or source.type == "MIX_RGB":
            f = min(max(f, 0.0), 1.0)
        if not fac_socket.is_linked and b_node is None and _image_node(a_node, a_from, owner):
            image_node = a_node
            factor = tuple(1.0 - f + f * c for c in tuple(b.default_value)[:3])
        elif not fac_socket.is_linked and a_node is None and f == 1.0 and _image_node(b_node, b_from, owner):
            image_node = b_node
            factor = tuple(tuple(a.default_value)[:3])
    if image_node is None:
        tell("%s: %s is linked to %r, which is not an image texture "
                   "(or a Multiply of one); its own colour is used", owner, name, source.name)
        return own, None, own
    if image_node.image is None:
        tell("%s: the image texture on %s has no image; the "
                   "socket's colour is used", owner, name)
        return own, None, own
    return factor, image_node.image, own


def surface_node(node_tree):
    """The shader node linked to the active output's Surface input (reroutes skipped)."""
    if node_tree is None:
        return None
    output = node_tree.get_output_node("EEVEE")
    if output is None:
        return None
    socket = output.inputs.get("Surface")
    while socket is not None and socket.is_linked:
        node = socket.links[0].from_node
        if node.type != "REROUTE":
            return node
        socket = node.inputs[0]
    return None


# Separate Color outputs -> the channel of hybrid_engine.scene.data.TEXTURE_CHANNELS they read.
_SEPARATED_CHANNELS = {"Red": 0, "Green": 1, "Blue": 2, "R": 0, "G": 1, "B": 2}


def _value_image(node, name: str, textures: dict | None, slot: str, owner: str) -> None:
    """Follow a value input (Roughness, Metallic) to the image that drives it: an Image
    Texture's Color (read as its luminance, Blender's colour-to-value conversion) or one
    channel of it through a Separate Color node (a glTF's packed image); the pixels go to
    ``textures[slot]`` and the channel to ``textures[slot channel]``. Other links are named
    in a warning and the socket's own value is used."""
    if textures is None or node is None:
        return
    source, from_socket = _linked_node(node.inputs.get(name))
    factor = _gltf_factor(source)
    if factor is not None and factor[0] in (0.0, 1.0):  # 0: the value is 0 (``_value``); 1: the image
        if factor[0] == 0.0:
            return
        source, from_socket = _linked_node(factor[1])
    if source is None:
        return
    channel = 3
    if source.type in ("SEPARATE_COLOR", "SEPRGB") and not source.mute and from_socket.name in _SEPARATED_CHANNELS:
        if source.type == "SEPARATE_COLOR" and getattr(source, "mode", "RGB") != "RGB":
            tell("%s: %s reads a %s Separate Color; its own value is used",
                       owner, name, source.mode)
            return
        channel = _SEPARATED_CHANNELS[from_socket.name]
        source, from_socket = _linked_node(source.inputs[0])
    image_node = _image_node(source, from_socket, owner)
    if image_node is None or image_node.image is None:
        tell("%s: %s is linked to %r, which is not an image texture "
                   "(or one channel of one); its own value is used", owner, name,
                   source.name if source is not None else "nothing")
        return
    pixels = image_pixels(image_node.image)
    if pixels is not None:
        textures[slot] = pixels
        textures[slot.replace("_texture", "_channel")] = channel


def _gltf_factor(source):
    """(factor, the other input) of a Multiply Math node with one constant input, as glTF
    imports a metallic or roughness factor over an image; None for anything else."""
    if source is None or source.type != "MATH" or source.mute or source.operation != "MULTIPLY" or source.use_clamp:
        return None
    first, second = source.inputs[0], source.inputs[1]
    for constant, other in ((first, second), (second, first)):
        if not constant.is_linked and other.is_linked:
            return float(constant.default_value), other
    return None


def _value(node, name: str, default: float) -> float:
    """A value input's own value, or 0 when a glTF factor of 0 multiplies what feeds it."""
    socket = node.inputs.get(name) if node is not None else None
    factor = _gltf_factor(_linked_node(socket)[0]) if socket is not None else None
    return 0.0 if factor is not None and factor[0] == 0.0 else socket_value(node, name, default)


def _value_images(node, textures: dict | None, owner: str) -> None:
    """The Principled BSDF's Roughness and Metallic images (``_value_image``)."""
    _value_image(node, "Roughness", textures, "roughness_texture", owner)
    _value_image(node, "Metallic", textures, "metallic_texture", owner)


def _normal_map(node, textures: dict | None, owner: str) -> float:
    """The strength of the tangent-space Normal Map node feeding ``node``'s Normal input
    from an image texture, with the image's pixels put in ``textures["normal_texture"]``; 1
    and nothing put when there is none (or no ``textures``). Other spaces and sources are
    named in a warning and left out (the shading normal is used)."""
    if textures is None or node is None:
        return 1.0
    source, _ = _linked_node(node.inputs.get("Normal"))
    if source is None:
        return 1.0
    if source.type != "NORMAL_MAP" or source.mute:
        tell("%s: the Normal input is fed by %r, which is not a Normal Map "
                   "node; the mesh's normals are used", owner, source.name)
        return 1.0
    if source.space != "TANGENT":
        tell("%s: Normal Map %r is in %s space; only tangent space is "
                   "read, the mesh's normals are used", owner, source.name, source.space)
        return 1.0
    image_source, from_socket = _linked_node(source.inputs.get("Color"))
    image_node = _image_node(image_source, from_socket, owner)
    if image_node is None or image_node.image is None:
        return 1.0
    pixels = image_pixels(image_node.image)
    if pixels is not None:
        textures["normal_texture"] = pixels
    return float(socket_value(source, "Strength", 1.0))


def material_inputs(material, textures: dict | None = None) -> dict:
    """Keyword arguments of ``principled_to_params`` read from a Blender material.

    Principled BSDF inputs are read directly; a lone Diffuse, Glossy, Glass or Emission
    shader is read as the Principled BSDF it is a special case of; anything else (or a
    material without a node tree) falls back to the viewport display values
    ``diffuse_color``/``metallic``/``roughness``.

    With a ``textures`` dict, the base colour and emission colour inputs follow links to
    Image Texture nodes (``_color_input``): the returned colour is then the factor the
    texture multiplies, and the image's pixels (``image_pixels``) go into
    ``textures["base_color_texture"]`` / ``textures["emission_texture"]``. Without one,
    linked inputs read as their own socket value.
    """
    thickness = getattr(getattr(material, "hybrid_rt", None), "thickness", DEFAULT_THICKNESS)
    node, _ = split_transparent(surface_node(getattr(material, "node_tree", None)), material.name)
    kind = node.type if node is not None else None

    def color(name: str, default, slot: str):
        if textures is None:
            return socket_value(node, name, default)
        factor, image, own = _color_input(node, name, default, material.name)
        pixels = image_pixels(image) if image is not None else None
        if pixels is None:
            return own
        textures[slot] = pixels
        return factor

    if kind == "BSDF_PRINCIPLED":
        _value_images(node, textures, material.name)
        return dict(
            base_color=color("Base Color", (0.8, 0.8, 0.8), "base_color_texture"),
            metallic=_value(node, "Metallic", 0.0),
            roughness=_value(node, "Roughness", 0.5),
            transmission=socket_value(node, "Transmission Weight", 0.0),
            ior=socket_value(node, "IOR", 1.5),
            specular_level=socket_value(node, "Specular IOR Level", 0.5),
            emission=color("Emission Color", (0.0, 0.0, 0.0), "emission_texture"),
            emission_strength=socket_value(node, "Emission Strength", 0.0),
            normal_strength=_normal_map(node, textures, material.name),
            thickness=thickness,
        )
    if kind == "EMISSION":
        return dict(base_color=(0.0, 0.0, 0.0), emission=color("Color", (0.8, 0.8, 0.8), "emission_texture"),
                    emission_strength=socket_value(node, "Strength", 1.0), thickness=thickness)
    if kind in ("BSDF_DIFFUSE", "BSDF_GLOSSY", "BSDF_ANISOTROPIC", "BSDF_GLASS"):
        base = color("Color", (0.8, 0.8, 0.8), "base_color_texture")
    if kind == "BSDF_DIFFUSE":
        return dict(base_color=base, roughness=1.0, specular_level=0.0, thickness=thickness)
    if kind in ("BSDF_GLOSSY", "BSDF_ANISOTROPIC"):
        return dict(base_color=base, metallic=1.0, roughness=socket_value(node, "Roughness", 0.5),
                    thickness=thickness)
    if kind == "BSDF_GLASS":
        return dict(base_color=base, transmission=1.0, roughness=socket_value(node, "Roughness", 0.0),
                    ior=socket_value(node, "IOR", 1.5), thickness=thickness)
    return dict(
        base_color=tuple(material.diffuse_color),
        metallic=float(material.metallic),
        roughness=float(material.roughness),
        thickness=thickness,
    )


def material_params(material, textures: bool = True) -> dict:
    """One ``MaterialTable`` row for a Blender material (shared by the exporter and the
    material panel, so the panel shows exactly what is rendered). With ``textures`` the
    row also holds the pixels of its base-colour and emission images (``MaterialTable.
    from_rows`` turns them into texture indices, one texture per image)."""
    row = _graph_row(material, textures)
    if row is None:
        images: dict | None = {} if textures else None
        row = principled_to_params(**material_inputs(material, images))
        row.update(images or {})
    # -- closure alpha: where the graph has an alpha program (hybrid_engine/scene/
    # closure_alpha.py), it gives the coverage; the row's reading is only the panel's, and
    # what it cannot read is no loss to tell the artist of.
    program = has_closure_alpha(row.get("node_graph"))
    row.update(surface_coverage(material, surface_node(getattr(material, "node_tree", None)), textures,
                                quiet=program))
    row["name"] = material.name
    return row


def _graph_row(material, textures: bool) -> dict | None:
    """The row of a material whose node graph the rows cannot hold (graph_rows.py), with its
    graph (``node_graph``) and the pixels its Image Textures index (``node_graph_textures``);
    None when the rows hold it (read by ``material_inputs``, the fast path)."""
    read = read_node_graph(material, images=textures)
    if read is None or read.graph.surface is None:
        return None
    if not read.structural and rows_hold(read.graph):
        return None
    # Kinds the reader knows but the compiler does not evaluate yet: named, never dropped
    # silently (their outputs take their default values in the program).
    for kind in sorted({node.kind for node in read.graph.nodes} - set(NODE_SPECS)):
        names = [node.name for node in read.graph.nodes if node.kind == kind]
        tell("%s: node %r (%s) is not evaluated yet; its outputs take their default values",
             material.name, names[0], kind)
    # An Attribute node of the View Layer type has no per-object value here: it reads as a
    # missing attribute, and the artist is told.
    for node in read.graph.nodes:
        if node.kind == "ATTRIBUTE" and node.settings.get("attribute_type") == "VIEW_LAYER":
            tell("%s: Attribute node %r: View Layer attributes are not evaluated yet; it reads 0",
                 material.name, node.name)
    thickness = getattr(getattr(material, "hybrid_rt", None), "thickness", DEFAULT_THICKNESS)
    row = principled_to_params(**stand_in_inputs(read.graph), thickness=thickness)
    row.update(node_graph=read.graph, node_graph_textures=read.images)
    return row


class MaterialTableBuilder:
    """Global material table; index 0 is the fallback for empty or missing slots, named as
    Cycles names its shader for them, so a Cryptomatte Material pass gives such faces the id
    Cycles gives them."""

    def __init__(self) -> None:
        self.rows = [dict(name="default_surface")]
        self._index: dict[int, int] = {}

    def index_of(self, material) -> int:
        if material is None:
            return 0
        original = material.original
        key = original.as_pointer()
        if key not in self._index:
            self._index[key] = len(self.rows)
            self.rows.append(material_params(original))
        return self._index[key]

    def table(self) -> MaterialTable:
        return table_with_graphs(self.rows)


def slot_lookup(obj, mesh, materials: MaterialTableBuilder) -> np.ndarray:
    """Global material id per material slot of this object (object-linked slots included)."""
    slots = obj.material_slots
    if len(slots):
        mats = [slot.material for slot in slots]
    else:  # temporary instance objects may carry their materials on the mesh only
        mats = list(mesh.materials)
    return np.array([materials.index_of(m) for m in mats] or [0], np.int32)
