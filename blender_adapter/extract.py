# SPDX-License-Identifier: GPL-3.0-or-later
"""Depsgraph → ``hybrid_engine.SceneData`` and ``Camera``.

The renderer core takes plain world-space arrays; this module is the one place that reads
Blender data to build them. It walks ``depsgraph.object_instances`` so that everything the
depsgraph evaluated is seen the way Blender's own engines see it: modifiers, shape keys,
armatures, geometry-nodes and collection instances, curves/text/metaballs that evaluate to
meshes. Hidden objects never reach us (the depsgraph filters by the render or viewport
visibility of its mode).

Speed matters because the viewport re-extracts on every geometry change and the per-frame
LBVH (paper §3.3) is rebuilt from these arrays: all per-element work is ``foreach_get`` into
numpy through Blender's raw attribute arrays plus vectorised gathers, never a Python loop over
vertices or triangles. Local mesh data is read once per evaluated mesh datablock and reused
by all its instances. Image textures linked to a material's base or emission colour are
read once per image content and kept across calls (``image_pixels``), so playback frames do
not read pixels again. Nothing here writes to Blender data.
"""
from __future__ import annotations

import functools
from collections import OrderedDict
import dataclasses
from dataclasses import dataclass

import numpy as np

from ..hybrid_engine.blackbody import blackbody_rgb
from ..hybrid_engine.camera import Camera, CameraError
from ..hybrid_engine.materials import DEFAULT_THICKNESS, principled_to_params
from ..hybrid_engine.instancing import ObjectMesh
from ..hybrid_engine.scene_data import MaterialTable, Sky
from ..hybrid_engine.solids import closed_outward_indexed
from . import colour, messages


# Object types whose evaluated geometry becomes a mesh through Object.to_mesh().
_CONVERTIBLE_TYPES = frozenset({"CURVE", "SURFACE", "FONT", "META"})
_LIGHT_TYPES = frozenset({"POINT", "SUN", "SPOT", "AREA"})

# Blender's default world colour when a scene has no World (DNA_world_defaults.h).
DEFAULT_WORLD_COLOR = (0.05, 0.05, 0.05)
# Lens Blender uses when the scene camera is not a camera object (BKE_camera_params_from_object).
NON_CAMERA_LENS = 35.0

# Triangulation: corner triangles whose split we cannot reproduce for certain are read from
# Blender one by one; past this many it is cheaper to read all of them with one foreach_get.
_EXACT_READ_LIMIT = 4096
# A quad is clearly convex (Blender keeps its 0-2 split) when the cosine between the two
# half-triangle normals, as in Blender's is_quad_flip_v3_first_third_fast, is below this.
_QUAD_CONVEX_COS = -0.1
# Meshes above this many triangles skip the closed-surface check (solids.py) and draw
# two-sided: the check sorts 3 edges per triangle, ~0.3 s per million.
CLOSED_CHECK_MAX_TRIANGLES = 1_000_000


# ---------------------------------------------------------------------------------------
# Materials
# ---------------------------------------------------------------------------------------
def _socket_value(node, name: str, default):
    """Default value of an input socket (links are not followed; colour sockets linked to an
    image go through ``_color_input``)."""
    socket = node.inputs.get(name)
    if socket is None or not hasattr(socket, "default_value"):
        return default
    value = socket.default_value
    return tuple(value) if hasattr(value, "__len__") else float(value)


# ---------------------------------------------------------------------------------------
# Image textures
# ---------------------------------------------------------------------------------------
# Pixels of images read so far, keyed by what identifies their content (``_image_key``): a
# playback frame or a viewport redraw reuses them instead of reading ``Image.pixels`` again
# (tens of milliseconds per megapixel). Least recently used images are dropped beyond this.
IMAGE_CACHE_BYTES = 1 << 30
_image_cache: OrderedDict[tuple, np.ndarray] = OrderedDict()
# The environment's RGB pixels, kept as one array per image content (``_environment_pixels``).
_environment_cache: dict[tuple, np.ndarray] = {}

# Byte images in this space, and ``is_data`` (Non-Color) ones, are read as they are: Blender
# 5's name for "whatever the scene works in".
_WORKING_SPACE_ALIAS = "Working Space"


def _tell(message: str, *args) -> None:
    """A message for the artist (messages.py: it reaches ``report``)."""
    messages.tell(message % args if args else message)


def forget_image_pixels() -> None:
    """Drop the cached image pixels (for callers that know an image was painted: in-memory
    edits of an already modified image do not change its cache key)."""
    _image_cache.clear()
    _environment_cache.clear()


def _image_key(image) -> tuple:
    """What identifies an image's pixels: the datablock, its source, size, colour space and
    modified state; a generated image also by its generator settings."""
    key = (image.session_uid, image.name_full, image.source, image.filepath_raw, tuple(image.size),
           int(image.channels), bool(image.is_float), image.colorspace_settings.name,
           bool(image.colorspace_settings.is_data), bool(image.is_dirty), image.packed_file is not None)
    if image.source == "GENERATED":
        key += (image.generated_type, tuple(image.generated_color), int(image.generated_width),
                int(image.generated_height), bool(image.use_generated_float))
    return key


def _byte_image_to_working_space(image, rgb: np.ndarray) -> np.ndarray:
    """A byte image's colours (in its own colour space, as Blender hands them back) in the
    scene's working space (colour.py); an unknown space is read as it is, and said so."""
    settings = image.colorspace_settings
    if settings.is_data or settings.name == _WORKING_SPACE_ALIAS:
        return rgb
    try:
        return colour.to_working_space(rgb, settings.name)
    except colour.ColourSpaceError as exc:
        _tell("image %r: %s; its values are used as they are", image.name_full, exc)
        return rgb


def image_pixels(image) -> np.ndarray | None:
    """An image as (H, W, 4) float32 linear RGBA, row 0 at the bottom (read-only, shared by
    every caller), or None when it has no pixels (missing file, empty image). Read once per
    image content (``_image_key``) with one ``foreach_get``."""
    if image.source not in ("FILE", "GENERATED"):
        _tell("image %r: %s images are not supported; the "
                   "socket's colour is used", image.name_full, image.source)
        return None
    key = _image_key(image)
    cached = _image_cache.get(key)
    if cached is not None:
        _image_cache.move_to_end(key)
        return cached
    width, height = (int(v) for v in image.size)
    channels = int(image.channels)
    if width < 1 or height < 1 or channels < 1:
        _tell("image %r has no pixels (missing file %r?); the "
                   "socket's colour is used", image.name_full, image.filepath)
        return None
    flat = np.empty(width * height * channels, np.float32)
    image.pixels.foreach_get(flat)
    pixels = flat.reshape(height, width, channels)
    out = np.ones((height, width, 4), np.float32)
    out[..., :3] = pixels[..., :3] if channels >= 3 else pixels[..., :1]
    if channels in (2, 4):
        out[..., 3] = pixels[..., -1]
    if not image.is_float:
        out[..., :3] = _byte_image_to_working_space(image, out[..., :3])
    out.flags.writeable = False  # shared by the cache and every scene that uses it
    _image_cache[key] = out
    total = sum(a.nbytes for a in _image_cache.values())
    while total > IMAGE_CACHE_BYTES and len(_image_cache) > 1:
        _, dropped = _image_cache.popitem(last=False)
        total -= dropped.nbytes
    return out


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
        _tell("%s: image texture %r uses %s extension; it is "
                   "sampled with REPEAT", owner, name, node.extension)
    if node.projection != "FLAT":
        _tell("%s: image texture %r uses %s projection; it "
                   "is sampled as FLAT", owner, name, node.projection)
    vector, _ = _linked_node(node.inputs.get("Vector"))
    if vector is not None and not (vector.type == "UVMAP" and not vector.uv_map) and vector.type != "TEX_COORD":
        _tell("%s: the vector input of image texture %r is "
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
        _tell("%s: %s is linked to %r, which is not an image texture "
                   "(or a Multiply of one); its own colour is used", owner, name, source.name)
        return own, None, own
    if image_node.image is None:
        _tell("%s: the image texture on %s has no image; the "
                   "socket's colour is used", owner, name)
        return own, None, own
    return factor, image_node.image, own


def _surface_node(node_tree):
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


# Separate Color outputs -> the channel of hybrid_engine.scene_data.TEXTURE_CHANNELS they read.
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
    if source is None:
        return
    channel = 3
    if source.type in ("SEPARATE_COLOR", "SEPRGB") and not source.mute and from_socket.name in _SEPARATED_CHANNELS:
        if source.type == "SEPARATE_COLOR" and getattr(source, "mode", "RGB") != "RGB":
            _tell("%s: %s reads a %s Separate Color; its own value is used",
                       owner, name, source.mode)
            return
        channel = _SEPARATED_CHANNELS[from_socket.name]
        source, from_socket = _linked_node(source.inputs[0])
    image_node = _image_node(source, from_socket, owner)
    if image_node is None or image_node.image is None:
        _tell("%s: %s is linked to %r, which is not an image texture "
                   "(or one channel of one); its own value is used", owner, name,
                   source.name if source is not None else "nothing")
        return
    pixels = image_pixels(image_node.image)
    if pixels is not None:
        textures[slot] = pixels
        textures[slot.replace("_texture", "_channel")] = channel


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
        _tell("%s: the Normal input is fed by %r, which is not a Normal Map "
                   "node; the mesh's normals are used", owner, source.name)
        return 1.0
    if source.space != "TANGENT":
        _tell("%s: Normal Map %r is in %s space; only tangent space is "
                   "read, the mesh's normals are used", owner, source.name, source.space)
        return 1.0
    image_source, from_socket = _linked_node(source.inputs.get("Color"))
    image_node = _image_node(image_source, from_socket, owner)
    if image_node is None or image_node.image is None:
        return 1.0
    pixels = image_pixels(image_node.image)
    if pixels is not None:
        textures["normal_texture"] = pixels
    return float(_socket_value(source, "Strength", 1.0))


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
    node = _surface_node(getattr(material, "node_tree", None))
    kind = node.type if node is not None else None

    def color(name: str, default, slot: str):
        if textures is None:
            return _socket_value(node, name, default)
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
            metallic=_socket_value(node, "Metallic", 0.0),
            roughness=_socket_value(node, "Roughness", 0.5),
            transmission=_socket_value(node, "Transmission Weight", 0.0),
            ior=_socket_value(node, "IOR", 1.5),
            specular_level=_socket_value(node, "Specular IOR Level", 0.5),
            emission=color("Emission Color", (0.0, 0.0, 0.0), "emission_texture"),
            emission_strength=_socket_value(node, "Emission Strength", 0.0),
            normal_strength=_normal_map(node, textures, material.name),
            thickness=thickness,
        )
    if kind == "EMISSION":
        return dict(base_color=(0.0, 0.0, 0.0), emission=color("Color", (0.8, 0.8, 0.8), "emission_texture"),
                    emission_strength=_socket_value(node, "Strength", 1.0), thickness=thickness)
    if kind in ("BSDF_DIFFUSE", "BSDF_GLOSSY", "BSDF_ANISOTROPIC", "BSDF_GLASS"):
        base = color("Color", (0.8, 0.8, 0.8), "base_color_texture")
    if kind == "BSDF_DIFFUSE":
        return dict(base_color=base, roughness=1.0, specular_level=0.0, thickness=thickness)
    if kind in ("BSDF_GLOSSY", "BSDF_ANISOTROPIC"):
        return dict(base_color=base, metallic=1.0, roughness=_socket_value(node, "Roughness", 0.5),
                    thickness=thickness)
    if kind == "BSDF_GLASS":
        return dict(base_color=base, transmission=1.0, roughness=_socket_value(node, "Roughness", 0.0),
                    ior=_socket_value(node, "IOR", 1.5), thickness=thickness)
    return dict(
        base_color=tuple(material.diffuse_color),
        metallic=float(material.metallic),
        roughness=float(material.roughness),
        thickness=thickness,
    )


def material_params(material, textures: bool = True) -> dict:
    """One ``MaterialTable`` row for a Blender material (shared by the extractor and the
    material panel, so the panel shows exactly what is rendered). With ``textures`` the
    row also holds the pixels of its base-colour and emission images (``MaterialTable.
    from_rows`` turns them into texture indices, one texture per image)."""
    images: dict | None = {} if textures else None
    row = principled_to_params(**material_inputs(material, images))
    row.update(images or {})
    row["name"] = material.name
    return row


class _MaterialTableBuilder:
    """Global material table; index 0 is the fallback for empty or missing slots."""

    def __init__(self) -> None:
        self.rows = [dict(name="fallback")]
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
        return MaterialTable.from_rows(self.rows)


def _slot_lookup(obj, mesh, materials: _MaterialTableBuilder) -> np.ndarray:
    """Global material id per material slot of this object (object-linked slots included)."""
    slots = obj.material_slots
    if len(slots):
        mats = [slot.material for slot in slots]
    else:  # temporary instance objects may carry their materials on the mesh only
        mats = list(mesh.materials)
    return np.array([materials.index_of(m) for m in mats] or [0], np.int32)


# ---------------------------------------------------------------------------------------
# Meshes
# ---------------------------------------------------------------------------------------
@dataclass
class _MeshData:
    """Local-space data of one evaluated mesh, read once and shared by its instances."""

    positions: np.ndarray  # (V, 3) float32
    tri_vertices: np.ndarray  # (N*3,) int32 vertex index per triangle corner
    normals: np.ndarray  # (D, 3) float32 unit, on the mesh's normal domain
    tri_normal_index: np.ndarray  # (N*3,) int32 index into normals per triangle corner
    slots: np.ndarray  # (N,) int32 material slot per triangle
    uvs: np.ndarray | None  # (N*3, 2) float32
    all_vertices_used: bool  # bounds may be taken over all vertices
    # Every edge borders two face corners' worth of loops (corners == 2 x edges): necessary
    # for a closed 2-manifold and free to test, so open meshes skip the full check.
    maybe_closed: bool = False
    # (vertices, corners, faces, triangles, normals domain): what a deformed re-read must
    # find unchanged to keep the topology (``reread_deformed``).
    shape: tuple = ()

    @property
    def triangle_count(self) -> int:
        return len(self.slots)

    @functools.cached_property
    def closed(self) -> bool:
        """Closed and wound outwards (hybrid_engine/solids.py): its instances' back faces
        may be culled. Checked once per evaluated mesh (the scene cache keeps unchanged
        meshes); meshes above CLOSED_CHECK_MAX_TRIANGLES are drawn two-sided instead of
        paying the check again on every deformed frame."""
        if not self.maybe_closed or self.triangle_count > CLOSED_CHECK_MAX_TRIANGLES:
            return False
        return closed_outward_indexed(self.positions, self.tri_vertices.reshape(-1, 3))


def _read(collection, attr: str, count: int, width: int, dtype) -> np.ndarray:
    out = np.empty(count * width, dtype)
    collection.foreach_get(attr, out)
    return out.reshape(count, width) if width > 1 else out


def _attribute(mesh, name: str, domain: str, data_type: str):
    attribute = mesh.attributes.get(name)
    if attribute is not None and attribute.domain == domain and attribute.data_type == data_type:
        return attribute
    return None


def _triangle_corners(mesh, positions: np.ndarray, corner_verts: np.ndarray,
                      tri_faces: np.ndarray) -> np.ndarray:
    """Corner index of each triangle corner, (N, 3), identical to ``mesh.loop_triangles``.

    Reading ``loop_triangles`` costs ~90 ns per triangle (no raw array behind it), most of
    the extraction budget. Instead the triangulation is reproduced from the raw face index
    of each triangle: faces own contiguous corner ranges in order, so each face's size is its
    triangle count + 2. Triangles are taken as they are; quads are split 0-2 unless Blender
    flips them to 1-3 (``mesh_tessellate.cc``: concave or degenerate quads). Blender has two
    flip tests (with and without the face normal); with the quad's normal ∝ a - b (a, b the
    half-triangle normals below) both keep the split whenever a·b < 0, so a clearly convex
    quad (a·b < -0.1 |a||b|) is safe from rounding either way. N-gons (polyfill + beautify)
    and unclear quads are read from Blender exactly.
    """
    n_tris, n_faces = len(tri_faces), len(mesh.polygons)
    sizes = (np.bincount(tri_faces, minlength=n_faces) + 2).astype(np.int32)
    if int(sizes.sum(dtype=np.int64)) != len(corner_verts):  # not the layout we rely on
        return _read(mesh.loop_triangles, "loops", n_tris, 3, np.int32)
    starts = np.zeros(n_faces, np.int32)
    np.cumsum(sizes[:-1], out=starts[1:])
    # Face f's triangles start at starts[f] - 2 f (each face of s corners has s - 2 triangles).
    face_first_tri = starts - 2 * np.arange(n_faces, dtype=np.int32)
    start = np.take(starts, tri_faces)
    local = np.arange(n_tris, dtype=np.int32) - np.take(face_first_tri, tri_faces)
    corners = np.empty((n_tris, 3), np.int32)
    corners[:, 0] = start
    np.add(start, local + 1, out=corners[:, 1])
    np.add(corners[:, 1], 1, out=corners[:, 2])
    tri_size = np.take(sizes, tri_faces)
    uncertain = tri_size > 4
    quad_first = np.flatnonzero((tri_size == 4) & (local == 0))
    if len(quad_first):
        # Blender's is_quad_flip_v3_first_third_fast: the quad keeps its 0-2 split when the
        # normals of (v0,v1,v2) and (v0,v3,v2) point opposite ways (a convex quad).
        s = np.take(start, quad_first)
        v0, v1, v2, v3 = (np.take(positions, np.take(corner_verts, s + k), axis=0) for k in range(4))
        d2 = v2 - v0
        cross_a = np.cross(v1 - v0, d2)
        cross_b = np.cross(v3 - v0, d2)
        dot = np.einsum("ij,ij->i", cross_a, cross_b)
        norms = np.einsum("ij,ij->i", cross_a, cross_a) * np.einsum("ij,ij->i", cross_b, cross_b)
        with np.errstate(invalid="ignore", over="ignore"):
            clear = (dot < 0) & (dot * dot > _QUAD_CONVEX_COS**2 * norms)
        unclear = quad_first[~clear]
        uncertain[unclear] = True
        uncertain[unclear + 1] = True
    exact = np.flatnonzero(uncertain)
    if len(exact) > _EXACT_READ_LIMIT:
        return _read(mesh.loop_triangles, "loops", n_tris, 3, np.int32)
    loop_triangles = mesh.loop_triangles
    for k in exact.tolist():  # few: only n-gons and concave/degenerate quads
        corners[k] = loop_triangles[k].loops
    return corners


def _sanitize_normals(normals: np.ndarray) -> np.ndarray:
    """Unit normals; zero or non-finite ones (degenerate faces) become +Z, the same
    documented fallback as ``scene_data.flat_normals``."""
    with np.errstate(invalid="ignore", over="ignore"):
        squared = np.einsum("ij,ij->i", normals, normals)
        if squared.min() > 0.999 and squared.max() < 1.001:  # Blender's own: unit already (NaN fails)
            return normals
        length = np.sqrt(squared)
        ok = np.isfinite(length) & (length > 0)
        if ok.all():
            return normals / length[:, None]
        out = np.zeros_like(normals)
        out[:, 2] = 1
        out[ok] = normals[ok] / length[ok, None]
    return out


def _read_mesh(mesh) -> _MeshData | None:
    """Local-space triangles of an evaluated mesh, or None when it has no faces."""
    tri_faces_collection = mesh.loop_triangle_polygons
    n_tris = len(tri_faces_collection)
    if n_tris == 0:
        return None
    n_verts, n_corners, n_faces = len(mesh.vertices), len(mesh.loops), len(mesh.polygons)
    tri_faces = _read(tri_faces_collection, "value", n_tris, 1, np.int32)

    position_attr = _attribute(mesh, "position", "POINT", "FLOAT_VECTOR")
    positions = _read(position_attr.data if position_attr else mesh.vertices,
                      "vector" if position_attr else "co", n_verts, 3, np.float32)
    corner_attr = _attribute(mesh, ".corner_vert", "CORNER", "INT")
    corner_verts = _read(corner_attr.data if corner_attr else mesh.loops,
                         "value" if corner_attr else "vertex_index", n_corners, 1, np.int32)
    corners = _triangle_corners(mesh, positions, corner_verts, tri_faces).reshape(-1)
    tri_vertices = np.take(corner_verts, corners)

    # Shading normals on the domain Blender stores them (smooth: vertex, flat: face,
    # sharp edges / custom split normals: corner); equal to mesh.corner_normals but cheaper.
    domain = mesh.normals_domain
    if domain == "POINT":
        normals = _read(mesh.vertex_normals, "vector", n_verts, 3, np.float32)
        normal_index = tri_vertices
    elif domain == "FACE":
        normals = _read(mesh.polygon_normals, "vector", n_faces, 3, np.float32)
        normal_index = np.repeat(tri_faces, 3)
    else:
        normals = _read(mesh.corner_normals, "vector", n_corners, 3, np.float32)
        normal_index = corners

    material_attr = _attribute(mesh, "material_index", "FACE", "INT")
    if material_attr is not None:
        slots = np.take(_read(material_attr.data, "value", n_faces, 1, np.int32), tri_faces)
    else:
        slots = np.zeros(n_tris, np.int32)

    uvs = None
    uv_layer = next((layer for layer in mesh.uv_layers if layer.active_render), None)
    if uv_layer is not None:
        uvs = np.take(_read(uv_layer.uv, "vector", n_corners, 2, np.float32), corners, axis=0)

    used = np.zeros(n_verts, bool)
    used[corner_verts] = True  # every corner of a face belongs to one of its triangles
    return _MeshData(
        shape=(n_verts, n_corners, n_faces, n_tris, domain),
        positions=positions,
        tri_vertices=tri_vertices.astype(np.int32, copy=False),
        normals=_sanitize_normals(normals),
        tri_normal_index=normal_index.astype(np.int32, copy=False),
        slots=slots,
        uvs=uvs,
        all_vertices_used=bool(used.all()),
        maybe_closed=n_corners == 2 * len(mesh.edges),
    )


def _mesh_shape(mesh) -> tuple:
    return (len(mesh.vertices), len(mesh.loops), len(mesh.polygons), len(mesh.loop_triangle_polygons),
            mesh.normals_domain)


def reread_deformed(mesh, previous: _MeshData | None) -> _MeshData | None:
    """A deformed mesh read again as positions and normals only, the topology (triangles,
    material slots, UVs) kept from ``previous`` when the mesh's counts and normal domain are
    unchanged: what an armature, a shape key or a Wave modifier changes. None when they
    differ (a new topology: read it whole with ``_read_mesh``)."""
    if previous is None or not previous.shape or _mesh_shape(mesh) != previous.shape:
        return None
    n_verts, n_corners, n_faces, _n_tris, domain = previous.shape
    position_attr = _attribute(mesh, "position", "POINT", "FLOAT_VECTOR")
    positions = _read(position_attr.data if position_attr else mesh.vertices,
                      "vector" if position_attr else "co", n_verts, 3, np.float32)
    if domain == "POINT":
        normals = _read(mesh.vertex_normals, "vector", n_verts, 3, np.float32)
    elif domain == "FACE":
        normals = _read(mesh.polygon_normals, "vector", n_faces, 3, np.float32)
    else:
        normals = _read(mesh.corner_normals, "vector", n_corners, 3, np.float32)
    data = dataclasses.replace(previous, positions=positions, normals=_sanitize_normals(normals))
    if "closed" in previous.__dict__:  # closedness is topology: keep the cached answer
        data.__dict__["closed"] = previous.__dict__["closed"]
    return data


def object_mesh(name: str, data: _MeshData, previous: ObjectMesh | None = None) -> ObjectMesh | None:
    """``data`` as the renderer's object-space mesh (hybrid_engine/instancing.py). A
    ``previous`` mesh read from the same topology (``reread_deformed``) gives a deformed
    version of it, so the GPU re-sends positions and normals only.

    Documented fallback: triangles with a NaN/inf corner cannot be rasterized or put in a
    BVH; they are dropped (with a warning) and the rest of the object renders. None when
    no triangle is left."""
    finite = bool(np.isfinite(data.positions).all())
    if previous is not None and finite and previous.triangle_count == data.triangle_count:
        return previous.deformed(data.positions, data.normals)
    corner_vertices, corner_normals, slots, uvs = data.tri_vertices, data.tri_normal_index, data.slots, data.uvs
    if not finite:
        n = data.triangle_count
        keep = np.isfinite(data.positions).all(axis=1)[corner_vertices].reshape(n, 3).all(axis=1)
        _tell("%s: %d triangle(s) with non-finite vertices skipped", name, int(n - keep.sum()))
        if not keep.any():
            return None
        corners = np.repeat(keep, 3)
        corner_vertices, corner_normals, slots = corner_vertices[corners], corner_normals[corners], slots[keep]
        uvs = uvs[corners] if uvs is not None else None
    return ObjectMesh(positions=data.positions, corner_vertices=corner_vertices, normals=data.normals,
                      corner_normals=corner_normals, slots=slots, uvs=uvs, closed=finite and data.closed)


# ---------------------------------------------------------------------------------------
# Lights and world
# ---------------------------------------------------------------------------------------
def _light_size(light) -> float:
    """Light.size of scene_data: point/spot radius, sun angular diameter, area half-size."""
    if light.type == "SUN":
        return float(getattr(light, "angle", 0.0))
    if light.type == "AREA":
        width = float(light.size)
        height = float(light.size_y) if light.shape in ("RECTANGLE", "ELLIPSE") else width
        return 0.5 * max(width, height)
    return float(getattr(light, "shadow_soft_size", 0.0))


def _unnormalized_area(light) -> float:
    """What Blender multiplies a lamp's power by when Normalize is off: the emitting area
    (the disc of a point or spot radius, the sun's disc in the sky), 1 without one."""
    if light.type == "AREA":
        width = float(light.size)
        height = float(light.size_y) if light.shape in ("RECTANGLE", "ELLIPSE") else width
        area = width * height * (np.pi / 4.0 if light.shape in ("DISK", "ELLIPSE") else 1.0)
    elif light.type == "SUN":
        area = np.pi * np.tan(0.5 * float(getattr(light, "angle", 0.0))) ** 2
    else:
        area = np.pi * float(getattr(light, "shadow_soft_size", 0.0)) ** 2
    return area if area > 0.0 else 1.0


def light_color(light) -> np.ndarray:
    """The lamp's colour times its power as Blender defines it: Power or Strength, times
    2^Exposure, times the black-body colour of its Temperature when that is in use, times
    the emitting area when Normalize is off."""
    color = np.asarray(light.color, np.float64) * float(light.energy) * 2.0 ** float(getattr(light, "exposure", 0.0))
    if getattr(light, "use_temperature", False):
        color = color * np.asarray(blackbody_rgb(float(light.temperature)))
    if not getattr(light, "normalize", True):
        color = color * _unnormalized_area(light)
    return color.astype(np.float32)


def _light_row(name: str, light, matrix: np.ndarray) -> dict:
    forward = -matrix[:3, 2]
    length = float(np.linalg.norm(forward))
    direction = forward / length if length > 0 else np.array([0.0, 0.0, -1.0])
    return dict(
        kind=light.type,
        position=matrix[:3, 3],
        direction=direction,
        color=light_color(light),
        radius=_light_size(light),
        spot_size=float(getattr(light, "spot_size", np.pi / 4)),
        spot_blend=float(getattr(light, "spot_blend", 0.15)),
        cast_shadow=bool(getattr(light, "use_shadow", True)),
        name=name,
    )


def _environment_pixels(image) -> np.ndarray | None:
    """(H, W, 3) linear float32 pixels of an environment image (row 0 = bottom), or None.
    Read by ``image_pixels`` (one read per image content, the textures' colour-space rule)
    and kept as the same array while the image stays the same, so that the GPU side (sky
    irradiance, mipmapped environment: sky_light.py) is not rebuilt by a render that only
    read the World again."""
    key = _image_key(image)
    cached = _environment_cache.get(key)
    if cached is not None:
        return cached
    pixels = image_pixels(image)
    if pixels is None:
        return None
    rgb = np.ascontiguousarray(pixels[..., :3])
    rgb.flags.writeable = False
    _environment_cache.clear()  # one World at a time is rendered
    _environment_cache[key] = rgb
    return rgb


def extract_sky(world) -> Sky:
    """The World background: Background node colour and strength, or an equirectangular
    Environment Texture linked to its Color; ``world.color`` when there is no Background
    node; Blender's default dark grey when the scene has no World."""
    if world is None:
        return Sky(color=DEFAULT_WORLD_COLOR, strength=1.0)
    node = _surface_node(world.node_tree)
    if node is None or node.type != "BACKGROUND":
        return Sky(color=tuple(world.color), strength=1.0)
    color = _socket_value(node, "Color", (0.05, 0.05, 0.05, 1.0))[:3]
    strength = float(_socket_value(node, "Strength", 1.0))
    environment = None
    color_socket = node.inputs.get("Color")
    if color_socket is not None and color_socket.is_linked:
        source = color_socket.links[0].from_node
        if source.type == "TEX_ENVIRONMENT" and source.image is not None:
            if source.projection == "EQUIRECTANGULAR":
                environment = _environment_pixels(source.image)
            else:
                _tell("World: environment projection %s is not supported; the background colour "
                      "is used", source.projection)
    return Sky(color=color, strength=strength, environment=environment)


# ---------------------------------------------------------------------------------------
# Scene
# ---------------------------------------------------------------------------------------
def _matrix(instance_or_object) -> np.ndarray:
    return np.array(instance_or_object.matrix_world, np.float64)


def render_resolution(render) -> tuple[int, int]:
    """The frame's size in pixels as Blender's render pipeline computes it
    (``BKE_render_resolution``: integer arithmetic, resolution * percentage / 100). A float
    scale gets some sizes one pixel short (100 px at 29 % is 28.999... px), and Blender then
    refuses the image."""
    percentage = int(render.resolution_percentage)
    return (max(int(render.resolution_x) * percentage // 100, 1),
            max(int(render.resolution_y) * percentage // 100, 1))


def camera_from_scene(scene, depsgraph=None) -> Camera:
    """The scene camera (evaluated when a depsgraph is given) and the render resolution.

    Raises ``CameraError`` when the scene has no camera or uses a panoramic one.
    """
    camera_object = scene.camera
    if camera_object is None:
        raise CameraError(f"scene {scene.name!r} has no active camera: set one in Scene "
                          "Properties > Camera")
    if depsgraph is not None:
        camera_object = camera_object.evaluated_get(depsgraph)
    render = scene.render
    width, height = render_resolution(render)
    common = dict(
        matrix_world=_matrix(camera_object),
        width=width,
        height=height,
        pixel_aspect_x=float(render.pixel_aspect_x),
        pixel_aspect_y=float(render.pixel_aspect_y),
    )
    if camera_object.type != "CAMERA":  # Blender renders from any object, with default optics
        return Camera(lens=NON_CAMERA_LENS, **common)
    data = camera_object.data
    if data.type not in ("PERSP", "ORTHO"):
        raise CameraError(
            f"camera {camera_object.name!r} is {data.type}: Hybrid RT renders perspective and "
            "orthographic cameras only"
        )
    return Camera(
        projection=data.type,
        lens=float(data.lens),
        sensor_width=float(data.sensor_width),
        sensor_height=float(data.sensor_height),
        sensor_fit=data.sensor_fit,
        shift_x=float(data.shift_x),
        shift_y=float(data.shift_y),
        clip_start=float(data.clip_start),
        clip_end=float(data.clip_end),
        ortho_scale=float(data.ortho_scale),
        **common,
    )
