# SPDX-License-Identifier: GPL-3.0-or-later
"""Meshes: an evaluated mesh read in object space (``MeshData``) and made the renderer's
``ObjectMesh`` (hybrid_engine/scene/meshes.py, scene/geometry.py), read once per evaluated mesh and shared by its
instances; a deformed mesh read again as positions and normals only."""
from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import numpy as np

from ...hybrid_engine.scene.mesh_attributes import DEFAULT_COLOR, as_rgba
from ...hybrid_engine.scene.meshes import ObjectMesh, usable_vertices
from ...hybrid_engine.scene.solids import closed_outward_indexed
from . import tell

# Object types whose evaluated geometry becomes a mesh through Object.to_mesh().
CONVERTIBLE_TYPES = frozenset({"CURVE", "SURFACE", "FONT", "META"})
# Triangulation: corner triangles whose split we cannot reproduce for certain are read from
# Blender one by one; past this many it is cheaper to read all of them with one foreach_get.
_EXACT_READ_LIMIT = 4096
# A quad is clearly convex (Blender keeps its 0-2 split) when the cosine between the two
# half-triangle normals, as in Blender's is_quad_flip_v3_first_third_fast, is below this.
_QUAD_CONVEX_COS = -0.1
# Meshes above this many triangles skip the closed-surface check (solids.py) and draw
# two-sided: the check sorts 3 edges per triangle on the host, a cost that grows with the
# mesh, so a very large mesh is spared it.
CLOSED_CHECK_MAX_TRIANGLES = 1_000_000


@dataclass
class MeshData:
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
    # The attributes the scene's programs read of this mesh (``read_attributes``), RGBA per
    # triangle corner, by the name the programs ask for; what a re-read needs to read them
    # again (each triangle corner's face corner and face) is kept only when there are some.
    attributes: dict[str, np.ndarray] | None = None
    attribute_names: tuple[str, ...] = ()
    corners: np.ndarray | None = None  # (N*3,) int32, only with attribute_names
    tri_faces: np.ndarray | None = None  # (N,) int32, only with attribute_names

    @property
    def triangle_count(self) -> int:
        return len(self.slots)

    @functools.cached_property
    def closed(self) -> bool:
        """Closed and wound outwards (hybrid_engine/scene/solids.py): its instances' back faces
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
    the exporter's budget. Instead the triangulation is reproduced from the raw face index
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


# Blender's attribute data types and the property their values are read through.
_ATTRIBUTE_READS = {"FLOAT": ("value", 1), "INT": ("value", 1), "BOOLEAN": ("value", 1), "INT8": ("value", 1),
                    "FLOAT2": ("vector", 2), "INT32_2D": ("value", 2), "FLOAT_VECTOR": ("vector", 3),
                    "FLOAT_COLOR": ("color", 4), "BYTE_COLOR": ("color", 4), "QUATERNION": ("value", 4)}


def _named_attribute(mesh, name: str):
    """The attribute a program's ``name`` means on ``mesh``: the default (render) colour
    attribute for ``DEFAULT_COLOR``, as Cycles' Color Attribute node without a layer."""
    if name == DEFAULT_COLOR:
        colors = mesh.color_attributes
        index = colors.render_color_index
        return colors[index] if 0 <= index < len(colors) else None
    return mesh.attributes.get(name)


def read_attributes(mesh, names: tuple[str, ...], tri_vertices: np.ndarray, corners: np.ndarray,
                    tri_faces: np.ndarray) -> dict[str, np.ndarray]:
    """The attributes ``names`` of ``mesh`` as RGBA per triangle corner
    (hybrid_engine/scene/mesh_attributes.py): a point value through each corner's vertex, a
    corner value through its face corner, a face value through its triangle's face. Byte
    colours read through ``color``, which Blender gives converted from sRGB to linear, as
    Cycles converts them; float colours as stored. A name the mesh lacks, or of a type or
    domain a program cannot read, is left out (it reads as missing)."""
    out = {}
    for name in names:
        attribute = _named_attribute(mesh, name)
        read = _ATTRIBUTE_READS.get(getattr(attribute, "data_type", ""))
        if attribute is None or read is None:
            continue
        prop, width = read
        domain = attribute.domain
        index = {"POINT": tri_vertices, "CORNER": corners, "FACE": np.repeat(tri_faces, 3)}.get(domain)
        if index is None:
            continue
        count = len(attribute.data)
        dtype = np.float32 if prop != "value" or attribute.data_type in ("FLOAT", "QUATERNION") else (
            bool if attribute.data_type == "BOOLEAN" else np.int32)
        values = _read(attribute.data, prop, count, width, dtype)
        out[name] = as_rgba(np.take(values.astype(np.float32, copy=False), index, axis=0))
    return out


def read_mesh(mesh, attribute_names: tuple[str, ...] = ()) -> MeshData | None:
    """Local-space triangles of an evaluated mesh, or None when it has no faces; with the
    attributes ``attribute_names`` (what the programs of its materials read; none costs
    nothing)."""
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
    attributes = None
    if attribute_names:
        attributes = read_attributes(mesh, attribute_names, tri_vertices, corners, tri_faces)
    return MeshData(
        attributes=attributes, attribute_names=tuple(attribute_names),
        corners=corners.astype(np.int32, copy=False) if attribute_names else None,
        tri_faces=tri_faces if attribute_names else None,
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


def reread_deformed(mesh, previous: MeshData | None, attribute_names: tuple[str, ...] = ()) -> MeshData | None:
    """A deformed mesh read again as positions and normals only, the topology (triangles,
    material slots, UVs) kept from ``previous`` when the mesh's counts and normal domain are
    unchanged: what an armature, a shape key or a Wave modifier changes, and with its
    ``attribute_names`` read again (a painted colour arrives as such an update). None when
    they differ (a new topology: read it whole with ``read_mesh``), or when attributes are
    asked of a read that kept no corners."""
    if previous is None or not previous.shape or _mesh_shape(mesh) != previous.shape:
        return None
    if attribute_names and previous.corners is None:
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
    attributes = (read_attributes(mesh, attribute_names, previous.tri_vertices, previous.corners, previous.tri_faces)
                  if attribute_names else None)
    data = dataclasses.replace(previous, positions=positions, normals=_sanitize_normals(normals),
                               attributes=attributes, attribute_names=tuple(attribute_names))
    if "closed" in previous.__dict__:  # closedness is topology: keep the cached answer
        data.__dict__["closed"] = previous.__dict__["closed"]
    return data


def object_mesh(name: str, data: MeshData, previous: ObjectMesh | None = None) -> ObjectMesh | None:
    """``data`` as the renderer's object-space mesh (hybrid_engine/scene/meshes.py, scene/geometry.py). A
    ``previous`` mesh read from the same topology (``reread_deformed``) gives a deformed
    version of it, so the GPU re-sends positions and normals only.

    Documented fallback: triangles with a NaN/inf corner (or one beyond ``VERTEX_LIMIT``,
    which is how Blender stores an infinite coordinate) cannot be rasterized or put in a
    BVH; they are dropped (with a warning) and the rest of the object renders. None when
    no triangle is left."""
    usable = usable_vertices(data.positions)
    finite = bool(usable.all())
    if previous is not None and finite and previous.triangle_count == data.triangle_count:
        return previous.deformed(data.positions, data.normals,
                                 attributes=data.attributes if data.attributes is not None else (
                                     {} if previous.attributes else None))
    corner_vertices, corner_normals, slots, uvs = data.tri_vertices, data.tri_normal_index, data.slots, data.uvs
    attributes = data.attributes
    if not finite:
        n = data.triangle_count
        keep = usable[corner_vertices].reshape(n, 3).all(axis=1)
        tell("%s: %d triangle(s) with non-finite vertices skipped", name, int(n - keep.sum()))
        if not keep.any():
            return None
        corners = np.repeat(keep, 3)
        corner_vertices, corner_normals, slots = corner_vertices[corners], corner_normals[corners], slots[keep]
        uvs = uvs[corners] if uvs is not None else None
        attributes = {name: values[corners] for name, values in attributes.items()} if attributes else attributes
    return ObjectMesh(positions=data.positions, corner_vertices=corner_vertices, normals=data.normals,
                      corner_normals=corner_normals, slots=slots, uvs=uvs, attributes=attributes,
                      closed=finite and data.closed)
