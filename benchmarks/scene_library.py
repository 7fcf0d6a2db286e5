# SPDX-License-Identifier: GPL-3.0-or-later
"""The paper's test scenes as real Blender scenes, shared by the demo, benchmarks and tests.

The paper (§4, Figure 4) measures its method on three animated scenes of 200 frames: Chess
(2,149,944 triangles), Sponza with the Buddha and the bunny (1,354,743) and San Miguel
(10,500,551). This module rebuilds them as ordinary Blender scenes so that one scene can be
rendered by HYBRID_RT, EEVEE and Cycles alike (the comparison pictures), and so that every
frame reaches the renderer along the user's path: depsgraph → the exporter (``scene_cache.py``) → core.

``build_scene(name, assets_dir, detail, frame_count)`` builds one of :data:`SCENES` into a
new ``bpy`` Scene of the running session (nothing of the user's is touched) and makes it the
window's active scene:

* ``chess`` -- the procedural Chess scene of ``benchmarks.scenes.chess``, needing no
  files: one object per piece, sphere, board, board frame and the floor, named as in the
  core; pieces of a type share one mesh (the core's template), moving objects are keyframed
  at every frame from the core's own placement functions, so a frame extracted from Blender
  equals ``build_chess(detail, frame)``.
* ``chess_real`` -- the same layout from nine copies of the Poly Haven chess set (linked
  duplicates: one mesh per piece for all nine sets), scaled so that a board square is one
  unit as in the core scene, the same piece motions, and nine dense mirror UV spheres whose
  tessellation fills the scene up to the paper's Chess count.
* ``sponza`` -- Crytek Sponza with the (decimated, 100 k) Happy Buddha, the Stanford bunny
  and the full Stanford dragon standing on the atrium floor: a gold mirror Buddha, a glass
  bunny that twists (a deformation: the mesh itself changes, not its transform), a chrome
  dragon that turns and slides; the camera circles the atrium.
* ``large`` -- **a stand-in for San Miguel**, which has no free copy: the ``sponza`` scene
  plus as many further Sponzas (collection instances on a grid) as it takes to reach the
  paper's San Miguel count of 10,500,551 triangles. The scene's name and its
  ``hybrid_rt_label`` custom property say so.

``detail`` scales the tessellation of the generated parts (chess, the spheres), decimates
the Stanford models (vertex clustering, below 1) and the number of Sponza copies (large),
so that tests load the real files yet stay small. Missing files raise
:class:`SceneAssetError` naming the file and the folder *before* anything is created; a
failure part-way through removes everything the build had created, so no half-built scene
is ever left behind.
"""
from __future__ import annotations

import contextlib
import gzip
import json
import logging
import math
import os
import shutil
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

import bpy
import numpy as np
from mathutils import Matrix, Vector

from hybrid_engine.scene.camera import look_at
from hybrid_engine.scene.data import LIGHT_KINDS

from .bench import FRAME_NEAR_SIZE
from .scene_parts import (box_mesh as _box_mesh, light as _light,
                          new_collection as _new_collection, new_mesh as _new_mesh, principled as _principled,
                          set_inputs as _set_inputs, world as _world)
from . import interior_scenes
from .scenes import chess as chess_core

log = logging.getLogger(__name__)
_TOLD_MISSING: set[Path] = set()  # glTF files whose missing textures were told

SCENES = ("chess", "chess_real", "sponza", "large", "room", *interior_scenes.INTERIOR_SCENES)
DEFAULT_FRAMES = chess_core.CHESS_FRAMES  # the paper's sequences are 200 frames long (§4)
DEFAULT_RESOLUTION = (1280, 720)  # the paper's 720p
MAX_DETAIL = chess_core.MAX_DETAIL
ASSETS_ENV = "HYBRID_RT_SCENES"  # the assets folder when none is given

# Triangle counts of the paper's scenes (Figure 4's caption).
PAPER_CHESS_TRIANGLES = 2_149_944
PAPER_SPONZA_TRIANGLES = 1_354_743
PAPER_SAN_MIGUEL_TRIANGLES = 10_500_551

# Files, relative to the assets folder (see its README.md). Sponza.gltf itself declares a
# required AMD extension that Blender's importer refuses; Sponza_blender.gltf is the same
# JSON without that declaration.
CHESS_SET_GLTF = "chess_polyhaven/chess_set_2k.gltf"
SPONZA_GLTF = "sponza/Sponza_blender.gltf"
BUDDHA_OBJ = "stanford/happy-buddha-100k.obj"  # decimated to 100 k triangles at the source
BUNNY_OBJ = "stanford/stanford-bunny.obj"
DRAGON_PLY_GZ = "stanford/dragon_vrip.ply.gz"  # ASCII PLY, gunzipped to a temporary folder
_SPONZA_FILES = (SPONZA_GLTF, BUDDHA_OBJ, BUNNY_OBJ, DRAGON_PLY_GZ)
ASSETS = {"chess": (), "chess_real": (CHESS_SET_GLTF,), "sponza": _SPONZA_FILES, "large": _SPONZA_FILES,
          "room": (), **interior_scenes.ASSETS}

CREDITS = {
    "chess": "procedural (benchmarks/scenes/chess.py)",
    "room": "procedural (benchmarks/scene_library.py)",
    "chess_real": "Chess Set by Poly Haven (CC0)",
    "sponza": "Crytek Sponza: Marko Dabrovic, Frank Meinl/Crytek, Morgan McGuire, Matthew Oliver "
    "(CC BY 3.0); Happy Buddha (decimated to 100k), bunny and dragon: Stanford Computer "
    "Graphics Laboratory, Stanford 3D Scanning Repository",
}
CREDITS["large"] = CREDITS["sponza"]
CREDITS.update(interior_scenes.CREDITS)

# -- chess_real ---------------------------------------------------------------------------------
CHESS_SETS = chess_core.SETS
MIN_SPHERE_RINGS = 8
# Materials as the core Chess scene's table (benchmarks/scenes/chess.py chess_materials):
# the Poly Haven board is one material, so it takes the mean of the two board rows.
CHESS_REAL_BOARD_REFLECTIVITY = 0.25

# -- sponza -------------------------------------------------------------------------------------
# Sponza_blender.gltf is in metres. Measured on the file (ray casts in bpy 5.0.1): its open
# atrium runs along x, floor at z ~ 3.98, free of columns for |x| < 14 and -2.4 < y < 4.1
# (the curtains); the models stand on its axis.
SPONZA_AXIS_Y = 0.85
SPONZA_RAY_START_Z = 60.0  # above the whole building (its top is at z ~ 23.6)
SPONZA_CAMERA_SEMI_AXES = (9.0, 2.6)  # the camera's ellipse around the atrium's centre
SPONZA_CAMERA_HEIGHT = (1.9, 0.4)  # eye height above the floor: mean, amplitude
SPONZA_NEAR_SIZE = 4.0  # the near cube holds the model next to the camera
SPONZA_CUBE_FAR = 200.0  # beyond the building's diagonal (~60 m)
LARGE_CUBE_FAR = 1000.0  # beyond the diagonal of the grid of Sponzas
# Cube-map thickness (paper §3.4) of the building: walls and columns are about this thick.
SPONZA_WALL_THICKNESS_M = 1.5
SPONZA_FLOOR_REFLECTIVITY = 0.25  # polished stone floor: reflects the models and the arcades
LARGE_GRID_GAP_M = 4.0  # between neighbouring Sponzas of the large scene

# (file, placement x on the atrium axis, size in metres, which extent the size applies to)
_MODEL_LAYOUT = {
    "buddha": (BUDDHA_OBJ, -5.0, 2.0, "height"),
    "dragon": (DRAGON_PLY_GZ, 0.0, 2.0, "length"),
    "bunny": (BUNNY_OBJ, 5.0, 1.2, "height"),
}
MODEL_THICKNESS_M = 1.0  # the models are about a metre deep
DRAGON_SLIDE_M = 1.0  # the dragon slides +-1 m along the axis while it turns once
BUNNY_TWIST_RAD = math.radians(30.0)  # amplitude of the bunny's twist (Simple Deform)
# Vertex clustering (detail < 1) stops refining the cell size within this fraction of its
# target triangle count.
CLUSTER_TOLERANCE = 0.15
CLUSTER_ITERATIONS = 8


class SceneAssetError(FileNotFoundError):
    """A file a scene needs is missing from the assets folder."""


# ---------------------------------------------------------------------------------------
# Assets
# ---------------------------------------------------------------------------------------
def _gltf_references(gltf: Path) -> tuple[list[str], list[str]]:
    """(buffers, images) that a .gltf file refers to by relative URI."""
    try:
        document = json.loads(gltf.read_text(encoding="utf-8"))
    except (OSError, ValueError) as error:
        raise SceneAssetError(f"{gltf} is not a readable glTF file: {error}") from error
    buffers = [b["uri"] for b in document.get("buffers", []) if "uri" in b and not b["uri"].startswith("data:")]
    # Images reached through a texture's core "source" (not through extensions such as
    # MSFT_texture_dds, which Blender's importer does not read).
    images = document.get("images", [])
    used = sorted({t["source"] for t in document.get("textures", []) if "source" in t})
    uris = [images[k]["uri"] for k in used if k < len(images) and "uri" in images[k]]
    return buffers, [uri for uri in uris if not uri.startswith("data:")]


def resolve_assets(assets_dir: str | os.PathLike | None) -> Path | None:
    """The assets folder: the argument, else the ``HYBRID_RT_SCENES`` environment variable."""
    if assets_dir is None:
        assets_dir = os.environ.get(ASSETS_ENV)
    return None if assets_dir is None else Path(assets_dir).expanduser().resolve()


def check_assets(name: str, assets_dir: str | os.PathLike | None) -> Path | None:
    """Check that every file scene ``name`` loads exists; returns the assets folder.

    Geometry is required: the listed files and the buffers their glTF files refer to. Missing
    textures only cost colour (Sponza's three curtain textures are absent from the snapshot
    this project uses), so they are logged, not fatal. Raises :class:`SceneAssetError`
    naming the first missing file and the folder it was expected in.
    """
    files = ASSETS[name]
    if not files:
        return None
    folder = resolve_assets(assets_dir)
    if folder is None:
        raise SceneAssetError(
            f"scene {name!r} loads {files[0]} (and {len(files) - 1} more file(s)) from an assets "
            f"folder: pass assets_dir or set {ASSETS_ENV}")
    for relative in files:
        path = folder / relative
        if not path.is_file():
            raise SceneAssetError(f"scene {name!r} needs {relative}: {path.name} is missing from "
                                  f"{path.parent}")
        if path.suffix == ".gltf":
            buffers, images = _gltf_references(path)
            for uri in buffers:
                if not (path.parent / uri).is_file():
                    raise SceneAssetError(f"scene {name!r} needs {uri} (geometry of {relative}): it is "
                                          f"missing from {path.parent}")
            missing = [uri for uri in images if not (path.parent / uri).is_file()]
            if missing and path not in _TOLD_MISSING:  # checked before loading and by the loader: told once
                _TOLD_MISSING.add(path)
                log.warning("%s: %d texture(s) missing from %s, those materials render untextured: %s",
                            relative, len(missing), path.parent, ", ".join(missing))
    return folder


# ---------------------------------------------------------------------------------------
# Blender helpers
# ---------------------------------------------------------------------------------------
_ID_COLLECTIONS = ("objects", "meshes", "materials", "images", "collections", "cameras", "lights",
                   "worlds", "actions", "node_groups", "textures", "curves", "scenes")


def _id_snapshot() -> set[int]:
    return {item.session_uid for attr in _ID_COLLECTIONS for item in getattr(bpy.data, attr)}


def _remove_created(before: set[int], previous_scene) -> None:
    """Remove every datablock created since ``before`` (a failed build leaves nothing)."""
    window = bpy.context.window
    if window is not None and previous_scene is not None and window.scene != previous_scene:
        window.scene = previous_scene
    created = [item for attr in _ID_COLLECTIONS for item in getattr(bpy.data, attr)
               if item.session_uid not in before]
    if created:
        bpy.data.batch_remove(created)


def _layer_collection(layer, collection):
    if layer.collection == collection:
        return layer
    for child in layer.children:
        found = _layer_collection(child, collection)
        if found is not None:
            return found
    return None


@contextlib.contextmanager
def _quiet_gltf_importer() -> Iterator[None]:
    # The glTF importer logs one INFO line per node unless Blender's debug value is 1
    # (io_scene_gltf2.set_debug_log); restored afterwards.
    previous = bpy.app.debug_value
    bpy.app.debug_value = 1
    try:
        yield
    finally:
        bpy.app.debug_value = previous


def _import(scene, collection, operator: Callable, **kwargs) -> list:
    """Run one of Blender's importers into ``collection``; returns the objects it created."""
    view_layer = scene.view_layers[0]
    view_layer.active_layer_collection = _layer_collection(view_layer.layer_collection, collection)
    before = {obj.session_uid for obj in bpy.data.objects}
    result = operator(**kwargs)
    if "FINISHED" not in result:
        raise RuntimeError(f"importing {kwargs.get('filepath')} failed ({result})")
    return [obj for obj in bpy.data.objects if obj.session_uid not in before]


def _remove_non_meshes(imported) -> None:
    """Drop the cameras, lights and empties an importer brought along (the library sets
    up its own); their data goes too when nothing else uses it."""
    for obj in [obj for obj in imported if obj.type != "MESH"]:
        data = obj.data
        bpy.data.objects.remove(obj)
        if isinstance(data, bpy.types.Camera) and data.users == 0:
            bpy.data.cameras.remove(data)
        elif isinstance(data, bpy.types.Light) and data.users == 0:
            bpy.data.lights.remove(data)


def _import_gltf_meshes(scene, collection, path: Path) -> list:
    """Import a glTF file into ``collection`` (images stay beside it, not packed) and keep
    only its meshes; returns them."""
    with _quiet_gltf_importer():
        imported = _import(scene, collection, bpy.ops.import_scene.gltf, filepath=str(path),
                           import_pack_images=False)
    meshes = [obj for obj in imported if obj.type == "MESH"]
    _remove_non_meshes(imported)
    return meshes


def _drop_missing_textures(materials) -> None:
    """Unlink Image Texture nodes whose file is missing (Sponza's three curtains), so every
    engine shows the socket's own colour instead of Blender's magenta "missing" colour."""
    dropped = []
    for material in materials:
        tree = material.node_tree
        for node in tree.nodes if tree is not None else ():
            image = getattr(node, "image", None) if node.type == "TEX_IMAGE" else None
            if image is None or image.packed_file is not None or Path(bpy.path.abspath(image.filepath)).is_file():
                continue
            for output in node.outputs:
                for link in list(output.links):
                    tree.links.remove(link)
            dropped.append(f"{material.name}: {Path(image.filepath).name}")
    if dropped:
        log.warning("textures missing, their materials use the socket colour: %s", "; ".join(dropped))


def _read_positions(mesh) -> np.ndarray:
    out = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", out)
    return out.reshape(-1, 3)


def _world_bounds(objects) -> np.ndarray:
    """(2, 3) bounds of mesh objects from their bounding boxes (cheap, exact for boxes)."""
    corners = [np.array(obj.bound_box) @ np.array(obj.matrix_world)[:3, :3].T + np.array(obj.matrix_world)[:3, 3]
               for obj in objects if obj.type == "MESH"]
    points = np.concatenate(corners)
    return np.stack([points.min(axis=0), points.max(axis=0)])


def _mesh_from_triangles(name: str, triangles: np.ndarray, normals: np.ndarray | None = None,
                         face_materials: np.ndarray | None = None):
    """A triangle-soup mesh (three vertices per triangle, order kept) with optional
    per-corner normals: the core's (N, 3, 3) arrays as they are."""
    n = len(triangles)
    return _new_mesh(name, np.asarray(triangles).reshape(-1, 3), np.arange(3 * n), np.arange(0, 3 * n, 3),
                     smooth=normals is not None,
                     corner_normals=None if normals is None else np.asarray(normals).reshape(-1, 3),
                     face_materials=face_materials)


def uv_sphere_rings(triangles: int) -> int:
    """Rings of a UV sphere with twice as many segments that has about ``triangles``
    triangles: 2 * segments * (rings - 1) = 4 R (R - 1)."""
    return max(MIN_SPHERE_RINGS, round(0.5 + 0.5 * math.sqrt(1.0 + float(triangles))))


def _uv_sphere(name: str, rings: int):
    """A welded unit UV sphere (2 * rings segments), smooth, outward winding."""
    segments = 2 * rings
    theta = np.pi * np.arange(1, rings) / rings  # latitude rows, from the bottom pole up
    phi = 2.0 * np.pi * np.arange(segments) / segments
    rows = np.stack([np.outer(np.sin(theta), np.cos(phi)), np.outer(np.sin(theta), np.sin(phi)),
                     np.repeat(-np.cos(theta)[:, None], segments, axis=1)], axis=-1).reshape(-1, 3)
    positions = np.concatenate([[(0.0, 0.0, -1.0)], rows, [(0.0, 0.0, 1.0)]])
    top = len(positions) - 1
    row = 1 + np.arange(rings - 1)[:, None] * segments  # first vertex of each row
    j = np.arange(segments)[None, :]
    nxt = (j + 1) % segments
    # Quads between rows i and i+1 (counter-clockwise seen from outside: +phi then up).
    a, b = row[:-1] + j, row[:-1] + nxt
    quads = np.stack([a, b, b + segments, a + segments], axis=-1).reshape(-1, 4)
    bottom = np.stack([np.zeros(segments, int), 1 + nxt[0], 1 + j[0]], axis=-1)
    last = row[-1, 0]
    cap = np.stack([last + j[0], last + nxt[0], np.full(segments, top)], axis=-1)
    corner_verts = np.concatenate([bottom.reshape(-1), quads.reshape(-1), cap.reshape(-1)])
    sizes = np.concatenate([np.full(segments, 3), np.full(len(quads), 4), np.full(segments, 3)])
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    return _new_mesh(name, positions, corner_verts, starts, smooth=True)


_LINEAR = bpy.types.Keyframe.bl_rna.properties["interpolation"].enum_items["LINEAR"].value


def _animate(id_data, channels: dict[tuple[str, int], np.ndarray], frames: np.ndarray) -> None:
    """Key ``id_data``'s channels at every frame (linear in between) with one action.

    ``channels[(data_path, index)]`` holds one value per frame. Keys are written with
    ``foreach_set`` into Blender 5's layered action (slot, layer, keyframe strip).
    """
    action = bpy.data.actions.new(f"{id_data.name} motion")
    slot = action.slots.new(id_type=id_data.id_type, name=id_data.name)
    strip = action.layers.new("motion").strips.new(type="KEYFRAME")
    channelbag = strip.channelbag(slot, ensure=True)
    for (path, index), values in channels.items():
        curve = channelbag.fcurves.new(path, index=index)
        keys = curve.keyframe_points
        keys.add(len(frames))
        keys.foreach_set("co", np.stack([frames, values], axis=1).astype(np.float32).reshape(-1))
        keys.foreach_set("interpolation", np.full(len(frames), _LINEAR, np.int32))
        curve.update()
    animation = id_data.animation_data or id_data.animation_data_create()
    animation.action = action
    animation.action_slot = slot


def _animate_transforms(obj, frames: np.ndarray, locations: np.ndarray | None = None,
                        euler: np.ndarray | None = None, scales: np.ndarray | None = None) -> None:
    channels = {}
    for path, values in (("location", locations), ("rotation_euler", euler), ("scale", scales)):
        if values is not None:
            channels.update({(path, k): values[:, k] for k in range(3)})
    _animate(obj, channels, frames)


def _add_mirror_spheres(collection, mesh, frames, frame_count: int) -> None:
    """The nine mirror spheres of both chess scenes, one per board, keyed with the core's
    sphere motion (scale keys only where a sphere's size changes)."""
    scales, centres = _sphere_motion(frames, frame_count)
    for b in range(chess_core.SETS):
        obj = bpy.data.objects.new(f"sphere_{b}", mesh)
        obj.location, obj.scale = centres[0, b], scales[0, b]
        collection.objects.link(obj)
        moving_scale = np.ptp(scales[:, b], axis=0).max() > 0
        _animate_transforms(obj, frames, locations=centres[:, b], scales=scales[:, b] if moving_scale else None)


def _eulers(rotations: np.ndarray) -> np.ndarray:
    """XYZ Euler angles of (F, 3, 3) rotations, each compatible with the previous one so that
    interpolated sub-frames never spin the long way round."""
    out = np.empty((len(rotations), 3))
    previous = None
    for k, rotation in enumerate(rotations):
        matrix = Matrix(rotation.tolist())
        euler = matrix.to_euler("XYZ") if previous is None else matrix.to_euler("XYZ", previous)
        out[k] = euler
        previous = euler
    return out


def _add_camera(scene, collection, name: str, matrices: np.ndarray, frames: np.ndarray, *, lens: float,
                clip_start: float, clip_end: float):
    """A perspective camera keyed at every frame from (F, 4, 4) world matrices."""
    data = bpy.data.cameras.new(name)
    data.lens, data.clip_start, data.clip_end = lens, clip_start, clip_end
    camera = bpy.data.objects.new(name, data)
    collection.objects.link(camera)
    camera.matrix_world = Matrix(matrices[0].tolist())
    _animate_transforms(camera, frames, locations=matrices[:, :3, 3], euler=_eulers(matrices[:, :3, :3]))
    scene.camera = camera
    return camera


def scene_triangle_count(depsgraph) -> int:
    """Triangles of every visible mesh instance of an evaluated depsgraph (instances counted
    once per placement, as the renderer sees them)."""
    total = 0
    counts: dict[int, int] = {}
    for instance in depsgraph.object_instances:
        if not instance.show_self or instance.object.type != "MESH":
            continue
        mesh = instance.object.data
        key = mesh.as_pointer()
        if key not in counts:
            counts[key] = len(mesh.loop_triangles)
        total += counts[key]
    return total


def _mesh_triangle_count(objects) -> int:
    return sum(len(obj.data.loop_triangles) for obj in objects if obj.type == "MESH")


def _frames(frame_count: int) -> np.ndarray:
    """Key frames 0..frame_count: the last equals the first for the periodic motions, so a
    looping playback of frames 0..frame_count-1 has no jump."""
    return np.arange(frame_count + 1, dtype=np.float64)


def _settings(scene, **values) -> None:
    for key, value in values.items():
        setattr(scene.hybrid_rt, key, value)


# ---------------------------------------------------------------------------------------
# chess: the core's procedural scene
# ---------------------------------------------------------------------------------------
def _chess_materials() -> dict[int, object]:
    """Blender materials for the rows of the core's MaterialTable, by row index.

    Principled inputs invert ``principled_to_params``: a row's reflectivity becomes Metallic
    with Roughness 0, its transmission Transmission Weight with Roughness 0; a diffuse row
    keeps Blender's default roughness (0.5), which reflects nothing.
    """
    table = chess_core.chess_materials()
    materials = {}
    for row, name in enumerate(table.names):
        reflectivity, transmission = float(table.reflectivity[row]), float(table.transmission[row])
        sharp = reflectivity > 0.0 or transmission > 0.0
        materials[row] = _principled(
            name, tuple(float(c) for c in table.base_color[row]), metallic=reflectivity,
            roughness=0.0 if sharp else 0.5, transmission=transmission, ior=float(table.ior[row]),
            thickness=float(table.thickness[row]))
    return materials


def _chess_lights(scene, collection) -> None:
    lights = chess_core.chess_lights()
    kinds = {value: key for key, value in LIGHT_KINDS.items()}
    for k, name in enumerate(lights.names):
        kind = kinds[int(lights.kind[k])]
        _light(scene, collection, name, kind, lights.color[k], position=tuple(lights.position[k]),
               direction=tuple(lights.direction[k]), radius=float(lights.radius[k]))


def _core_frames(frames: np.ndarray, frame_count: int) -> np.ndarray:
    """The core chess frame shown at each Blender frame: the core's 200-frame period is
    stretched over ``frame_count`` frames (identical frames when frame_count is 200)."""
    return frames * (chess_core.CHESS_FRAMES / frame_count)


def _chess_camera(scene, collection, frames: np.ndarray, frame_count: int) -> None:
    width, height = scene.render.resolution_x, scene.render.resolution_y
    cameras = [chess_core.camera_path(f, width, height) for f in _core_frames(frames, frame_count)]
    first = cameras[0]
    _add_camera(scene, collection, "chess camera", np.stack([c.matrix_world for c in cameras]), frames,
                lens=first.lens, clip_start=first.clip_start, clip_end=first.clip_end)


def _sphere_motion(frames: np.ndarray, frame_count: int) -> tuple[np.ndarray, np.ndarray]:
    """(F, 9, 3) sphere scales (the diagonal of the core's linear maps) and (F, 9, 3) centres."""
    motion = [chess_core.sphere_placements(f) for f in _core_frames(frames, frame_count)]
    scales = np.stack([np.diagonal(maps, axis1=1, axis2=2) for maps, _ in motion])
    centres = np.stack([centres for _, centres in motion])
    return scales, centres


def _build_chess(scene, assets: Path | None, detail: float, frame_count: int) -> None:
    """The core Chess scene (benchmarks/scenes/chess.py) as Blender objects.

    Static parts (floor, boards, board frames) are taken from ``build_chess(detail, 0)`` in
    world space. Pieces and spheres are instances of the core's templates: one mesh per piece
    type, placed by the core's own ``piece_placements``/``sphere_placements`` at every frame; only objects
    that move get keys. Object and material names are the core's, so a frame extracted from
    this scene can be compared object by object with ``build_chess(detail, frame)``.
    """
    frames = _frames(frame_count)
    core_frames = _core_frames(frames, frame_count)
    materials = _chess_materials()
    static_collection = _new_collection(scene, "chess boards")
    piece_collection = _new_collection(scene, "chess pieces")
    rig = _new_collection(scene, "chess camera and lights")

    reference, _ = chess_core.build_chess(detail, 0, 16, 16)
    geometry = reference.geometry
    n_static = 1 + 2 * chess_core.SETS  # floor, boards, board frames come first in the core
    for k in range(n_static):
        first, count = geometry.object_ranges[k]
        ids = geometry.material_ids[first:first + count]
        slots, face_slots = np.unique(ids, return_inverse=True)
        mesh = _mesh_from_triangles(geometry.object_names[k], geometry.triangles[first:first + count],
                                    face_materials=face_slots)
        for row in slots:
            mesh.materials.append(materials[int(row)])
        static_collection.objects.link(bpy.data.objects.new(geometry.object_names[k], mesh))

    templates = chess_core.piece_templates(detail)
    meshes = {}
    for kind, (tris, normals) in templates.items():
        meshes[kind] = _mesh_from_triangles(f"chess {kind}", tris, normals)
    meshes["sphere"].materials.append(materials[chess_core.MAT_SPHERE])

    # Pieces: the core's placement at every frame; one object each, sharing its type's mesh.
    placements = [chess_core.piece_placements(f) for f in core_frames]
    positions = np.array([[p["position"] for p in frame] for frame in placements])  # (F, 288, 3)
    angles = np.array([[p["angle"] for p in frame] for frame in placements])
    for k, piece in enumerate(placements[0]):
        mesh = meshes[piece["kind"]]
        if not mesh.materials:
            mesh.materials.append(materials[piece["material"]])
        obj = bpy.data.objects.new(piece["name"], mesh)
        obj.material_slots[0].link = "OBJECT"  # white and black share the type's mesh
        obj.material_slots[0].material = materials[piece["material"]]
        obj.location = positions[0, k]
        obj.rotation_euler = (0.0, 0.0, angles[0, k])
        piece_collection.objects.link(obj)
        if np.ptp(positions[:, k], axis=0).max() > 0 or np.ptp(angles[:, k]) > 0:
            euler = np.zeros((len(frames), 3))
            euler[:, 2] = angles[:, k]
            _animate_transforms(obj, frames, locations=positions[:, k], euler=euler)

    _add_mirror_spheres(piece_collection, meshes["sphere"], frames, frame_count)

    _chess_lights(scene, rig)
    _chess_camera(scene, rig, frames, frame_count)
    sky = reference.sky
    _world(scene, tuple(float(c) for c in sky.color), float(sky.strength))
    # Final renders take 16 samples, as the room's: edges and soft-shadow penumbrae are
    # compared with Cycles' and EEVEE's converged pictures (playback and timing take one).
    _settings(scene, near_size=FRAME_NEAR_SIZE, cube_far=chess_core.CHESS_CUBE_FAR, render_samples=16)
    scene["hybrid_rt_label"] = (f"Chess, procedural (288 pieces, 9 mirror spheres): "
                                f"{chess_core.chess_triangle_count(detail):,} triangles "
                                f"(paper: {PAPER_CHESS_TRIANGLES:,})")


# ---------------------------------------------------------------------------------------
# chess_real: nine Poly Haven chess sets
# ---------------------------------------------------------------------------------------
def _parse_piece(name: str) -> tuple[str, str] | None:
    """(kind, colour) from a Poly Haven object name such as ``piece_knight_black_02``."""
    parts = name.split(".")[0].split("_")
    if len(parts) >= 3 and parts[0] == "piece" and parts[2] in ("white", "black"):
        return parts[1], parts[2]
    return None


def _chess_set_frame(objects) -> tuple[np.ndarray, float]:
    """The 4x4 map from the imported set to the core's board frame (squares of one unit,
    board centre at the origin, board top at z = 0, white on -y) and the board top's
    height above the board's underside in those units."""
    pieces = [obj for obj in objects if _parse_piece(obj.name)]
    if len(pieces) != chess_core.PIECES_PER_SET:
        raise RuntimeError(f"the chess set has {len(pieces)} pieces, expected {chess_core.PIECES_PER_SET}")
    locations = np.array([obj.matrix_world.translation for obj in pieces])
    centre = locations.mean(axis=0)  # the starting position is symmetric
    # The pieces cover 8 x 8 squares: their centres span 7 squares along both axes.
    square = float(np.ptp(locations[:, :2], axis=0).mean()) / (chess_core.BOARD_SQUARES - 1)
    white = np.array([obj.matrix_world.translation for obj in pieces if _parse_piece(obj.name)[1] == "white"])
    side = white.mean(axis=0)[:2] - centre[:2]
    # Rotate about Z so that white sits on -y, as in the core scene.
    angle = -math.pi / 2 - math.atan2(side[1], side[0])
    frame = (np.array(Matrix.Rotation(angle, 4, "Z")) @ np.diag([1 / square, 1 / square, 1 / square, 1.0])
             @ np.array(Matrix.Translation(Vector(-centre))))
    board = next(obj for obj in objects if obj.type == "MESH" and not _parse_piece(obj.name))
    board_bottom = _world_bounds([board])[0, 2]
    return frame, float((centre[2] - board_bottom) / square)


def _chess_real_materials(pieces) -> None:
    """Mirror and glass variants of the Poly Haven materials, textures kept on Base Color.

    As the core scene: white pieces reflect 0.8, black 0.7, the white bishops are clear
    glass (IOR 1.5), the board reflects a little; Metallic and Roughness lose their texture
    links (a mirror is smooth everywhere). Thicknesses are the core's (see chess.py).
    """
    table = chess_core.chess_materials()
    row = {name: k for k, name in enumerate(table.names)}
    white_mesh = next(obj.data for obj in pieces if _parse_piece(obj.name)[1] == "white")
    black_mesh = next(obj.data for obj in pieces if _parse_piece(obj.name)[1] == "black")
    white, black = white_mesh.materials[0], black_mesh.materials[0]
    glass = white.copy()
    glass.name = "chess_set_pieces_glass"
    for material, key in ((white, "piece_white_mirror"), (black, "piece_black_mirror")):
        _set_inputs(material, Metallic=float(table.reflectivity[row[key]]), Roughness=0.0)
        material.hybrid_rt.thickness = float(table.thickness[row[key]])
    _set_inputs(glass, Metallic=0.0, Roughness=0.0, **{"Transmission Weight": 1.0},
                IOR=float(table.ior[row["piece_glass"]]))
    glass.hybrid_rt.thickness = float(table.thickness[row["piece_glass"]])
    for obj in pieces:
        if _parse_piece(obj.name) == ("bishop", "white"):
            obj.data.materials[0] = glass


def _build_chess_real(scene, assets: Path, detail: float, frame_count: int) -> None:
    """Nine Poly Haven chess sets in the core Chess layout (see the module docstring)."""
    frames = _frames(frame_count)
    core_frames = _core_frames(frames, frame_count)
    sets = _new_collection(scene, "chess sets (Poly Haven)")
    rig = _new_collection(scene, "chess camera and lights")
    meshes = _import_gltf_meshes(scene, sets, assets / CHESS_SET_GLTF)
    set_triangles = _mesh_triangle_count(meshes)
    to_board, board_height = _chess_set_frame(meshes)
    pieces = [obj for obj in meshes if _parse_piece(obj.name)]
    _drop_missing_textures({slot.material for obj in meshes for slot in obj.material_slots if slot.material})
    _chess_real_materials(pieces)

    # The core's piece placement drives the matching Poly Haven piece (same colour, kind
    # and square): the core's displacement from frame 0 is added to the piece's position.
    placements = [chess_core.piece_placements(f) for f in core_frames]
    by_name = {p["name"]: k for k, p in enumerate(placements[0])}
    positions = np.array([[p["position"] for p in frame] for frame in placements])
    offsets = positions - positions[:1]
    sources = [(obj, obj.name.split(".")[0], np.array(obj.matrix_world), _parse_piece(obj.name)) for obj in meshes]
    for b, centre in enumerate(chess_core.board_centers()):
        to_world = np.array(Matrix.Translation(Vector(centre))) @ to_board
        for source, name, matrix, identity in sources:
            obj = source if b == 0 else source.copy()  # linked duplicate: the mesh is shared
            if b:
                sets.objects.link(obj)
            obj.matrix_world = Matrix((to_world @ matrix).tolist())
            obj.name = f"set{b}_{name}"
            if identity is None:
                continue
            x, y = np.array(obj.matrix_world.translation)[:2] - centre[:2]
            col, row = round(x + 3.5), round(y + 3.5)
            core_name = f"set{b}_{identity[1]}_{identity[0]}_{'abcdefgh'[col]}{row + 1}"
            k = by_name.get(core_name)
            if k is not None and np.abs(offsets[:, k]).max() > 0:
                _animate_transforms(obj, frames, locations=np.array(obj.location) + offsets[:, k])

    # Floor, as the core scene's, under the boards.
    half = chess_core.FLOOR_HALF_SIZE
    floor_z = -board_height
    floor = _mesh_from_triangles("floor", chess_core.quad((0.0, 0.0, floor_z), (half, 0, 0), (0, half, 0)))
    table = chess_core.chess_materials()
    floor_row = table.names.index("floor")
    floor.materials.append(_principled("floor", tuple(float(c) for c in table.base_color[floor_row]),
                                       thickness=float(table.thickness[floor_row])))
    sets.objects.link(bpy.data.objects.new("floor", floor))
    for source in (obj for obj, _, _, identity in sources if identity is None):  # the board
        _set_inputs(source.data.materials[0], Metallic=CHESS_REAL_BOARD_REFLECTIVITY, Roughness=0.0)
        source.data.materials[0].hybrid_rt.thickness = float(table.thickness[table.names.index("board_dark")])

    # Nine dense mirror spheres: at detail 1 they fill the scene up to the paper's count.
    per_sphere = (PAPER_CHESS_TRIANGLES - CHESS_SETS * set_triangles - len(floor.loop_triangles)) / CHESS_SETS
    sphere_mesh = _uv_sphere("mirror sphere", uv_sphere_rings(detail * per_sphere))
    sphere_row = table.names.index("sphere_mirror")
    sphere_mesh.materials.append(_principled(
        "sphere_mirror", tuple(float(c) for c in table.base_color[sphere_row]),
        metallic=float(table.reflectivity[sphere_row]), roughness=0.0,
        thickness=float(table.thickness[sphere_row])))
    _add_mirror_spheres(sets, sphere_mesh, frames, frame_count)

    _chess_lights(scene, rig)
    _chess_camera(scene, rig, frames, frame_count)
    sky = chess_core.chess_sky()
    _world(scene, tuple(float(c) for c in sky.color), float(sky.strength))
    # Final renders take 16 samples, as the room's: edges and soft-shadow penumbrae are
    # compared with Cycles' and EEVEE's converged pictures (playback and timing take one).
    _settings(scene, near_size=FRAME_NEAR_SIZE, cube_far=chess_core.CHESS_CUBE_FAR, render_samples=16)
    total = CHESS_SETS * (set_triangles + len(sphere_mesh.loop_triangles)) + len(floor.loop_triangles)
    scene["hybrid_rt_label"] = (f"Chess from {CHESS_SETS} Poly Haven chess sets (288 pieces) and {CHESS_SETS} "
                                f"mirror spheres: {total:,} triangles (paper: {PAPER_CHESS_TRIANGLES:,})")


# ---------------------------------------------------------------------------------------
# sponza: Sponza + Buddha + bunny + dragon
# ---------------------------------------------------------------------------------------
def cluster_decimate(positions: np.ndarray, triangles: np.ndarray, target: int) -> tuple[np.ndarray, np.ndarray]:
    """Vertex-clustering decimation (Rossignac & Borrel 1993) to about ``target`` triangles.

    Vertices are snapped to a uniform grid, each occupied cell becomes one vertex at the mean
    of its vertices, and triangles whose corners fall into fewer than three cells vanish. The
    cell size is refined (triangle count ~ 1 / cell²) until the count is within
    :data:`CLUSTER_TOLERANCE` of the target. Vectorised: the 871 k-triangle dragon takes a
    fraction of a second, where Blender's Decimate modifier takes seconds.
    """
    positions = np.asarray(positions, np.float64)
    triangles = np.asarray(triangles, np.int64)
    lo = positions.min(axis=0)
    extent = float(np.ptp(positions, axis=0).max())
    if target >= len(triangles) or extent <= 0:
        return positions.astype(np.float32), triangles.astype(np.int32)

    def cluster(cell: float):
        keys = np.floor((positions - lo) / cell).astype(np.int64)
        dims = keys.max(axis=0) + 1
        flat = (keys[:, 0] * dims[1] + keys[:, 1]) * dims[2] + keys[:, 2]
        cells, vertex_cell = np.unique(flat, return_inverse=True)
        tris = vertex_cell[triangles]
        keep = (tris[:, 0] != tris[:, 1]) & (tris[:, 1] != tris[:, 2]) & (tris[:, 0] != tris[:, 2])
        tris = tris[keep]
        # Two triangles over the same three cells collapse into one.
        _, first = np.unique(np.sort(tris, axis=1), axis=0, return_index=True)
        return len(cells), vertex_cell, tris[np.sort(first)]

    cell = extent / math.sqrt(max(target, 1))
    for _ in range(CLUSTER_ITERATIONS):
        n_cells, vertex_cell, tris = cluster(cell)
        if abs(len(tris) / target - 1.0) <= CLUSTER_TOLERANCE:
            break
        cell *= math.sqrt(max(len(tris), 1) / target)
    counts = np.bincount(vertex_cell, minlength=n_cells).astype(np.float64)
    merged = np.stack([np.bincount(vertex_cell, positions[:, k], n_cells) for k in range(3)], axis=1)
    merged /= np.maximum(counts, 1)[:, None]
    used = np.unique(tris)  # drop cells whose triangles all vanished
    remap = np.full(n_cells, -1, np.int64)
    remap[used] = np.arange(len(used))
    return merged[used].astype(np.float32), remap[tris].astype(np.int32)


def _triangles_of(mesh) -> np.ndarray:
    mesh.calc_loop_triangles()
    out = np.empty(len(mesh.loop_triangles) * 3, np.int32)
    mesh.loop_triangles.foreach_get("vertices", out)
    return out.reshape(-1, 3)


def _prepare_model(obj, detail: float, size: float, extent: str) -> None:
    """Decimate (detail < 1), stand the mesh on its origin (centre of its base), smooth it
    and scale the object so that its height or horizontal length is ``size`` metres."""
    mesh = obj.data
    # The importers turn Y-up files upright with the object's rotation: bake it into the
    # mesh, so that the mesh's z is up and the object holds only our placement.
    mesh.transform(obj.matrix_basis)
    obj.matrix_basis = Matrix.Identity(4)
    positions = _read_positions(mesh).astype(np.float64)
    if detail < 1.0:
        triangles = _triangles_of(mesh)
        positions, triangles = cluster_decimate(positions, triangles, max(int(detail * len(triangles)), 64))
        new = _new_mesh(mesh.name, positions, triangles.reshape(-1), np.arange(0, triangles.size, 3), smooth=True)
        obj.data = new
        bpy.data.meshes.remove(mesh)
        mesh = new
    lo, hi = positions.min(axis=0), positions.max(axis=0)
    base = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]])
    mesh.transform(Matrix.Translation(Vector(-base)))
    mesh.shade_smooth()
    measured = (hi[2] - lo[2]) if extent == "height" else float(max(hi[0] - lo[0], hi[1] - lo[1]))
    scale = size / measured
    obj.scale = (scale, scale, scale)


def _floor_height(scene, x: float, y: float, fallback: float) -> float:
    """Height of the floor under (x, y), found by a ray cast down through the open roof."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    hit, location, *_ = scene.ray_cast(depsgraph, Vector((x, y, SPONZA_RAY_START_Z)), Vector((0.0, 0.0, -1.0)))
    if not hit:
        # Fallback: the building's lowest point (only if the file changed and the atrium moved).
        log.warning("no floor found under (%.2f, %.2f); using z = %.2f", x, y, fallback)
        return fallback
    return float(location.z)


def _import_sponza(scene, assets: Path, cube_far: float):
    """Sponza into its own collection; its cameras are dropped (the scene has its own)."""
    building = _new_collection(scene, "Sponza (Crytek)")
    meshes = _import_gltf_meshes(scene, building, assets / SPONZA_GLTF)
    materials = {slot.material for obj in meshes for slot in obj.material_slots if slot.material}
    _drop_missing_textures(materials)
    for material in materials:
        material.hybrid_rt.thickness = min(SPONZA_WALL_THICKNESS_M / cube_far, 1.0)
        if material.name.split(".")[0] == "Floor":
            _set_inputs(material, Metallic=SPONZA_FLOOR_REFLECTIVITY, Roughness=0.0)
    return building, meshes


def _import_models(scene, assets: Path, detail: float, collection, floor_z: float, cube_far: float) -> dict:
    """Buddha, dragon and bunny on the atrium's axis, standing on the floor."""
    models = {}
    with tempfile.TemporaryDirectory(prefix="hybrid_rt_scene_") as temporary:
        for name, (relative, x, size, extent) in _MODEL_LAYOUT.items():
            path = assets / relative
            if path.suffix == ".gz":
                unpacked = Path(temporary) / path.stem
                with gzip.open(path, "rb") as source, open(unpacked, "wb") as target:
                    shutil.copyfileobj(source, target)
                # The Stanford scans are Y-up; convert as the OBJ importer does by default.
                new = _import(scene, collection, bpy.ops.wm.ply_import, filepath=str(unpacked),
                              forward_axis="NEGATIVE_Z", up_axis="Y")
            else:
                new = _import(scene, collection, bpy.ops.wm.obj_import, filepath=str(path))
            obj = new[0]
            obj.name = name
            _prepare_model(obj, detail, size, extent)
            obj.location = (x, SPONZA_AXIS_Y, floor_z)
            models[name] = obj
    thickness = min(MODEL_THICKNESS_M / cube_far, 1.0)
    finishes = {
        "buddha": dict(base_color=(1.0, 0.78, 0.34), metallic=1.0, roughness=0.0),  # gold mirror
        "dragon": dict(base_color=(0.9, 0.9, 0.92), metallic=1.0, roughness=0.0),  # chrome mirror
        "bunny": dict(base_color=(1.0, 1.0, 1.0), roughness=0.0, transmission=1.0, ior=1.5),  # glass
    }
    for name, obj in models.items():
        obj.data.materials.clear()
        obj.data.materials.append(_principled(f"{name} {'glass' if name == 'bunny' else 'mirror'}",
                                              thickness=thickness, **finishes[name]))
    return models


def _animate_models(models: dict, frames: np.ndarray, frame_count: int) -> None:
    """The dragon turns once and slides along the axis; the bunny twists (its mesh deforms
    through a Simple Deform modifier, so its object transform stays put)."""
    t = frames / frame_count
    dragon = models["dragon"]
    locations = np.repeat(np.array(dragon.location)[None, :], len(frames), axis=0)
    locations[:, 0] += DRAGON_SLIDE_M * np.sin(2.0 * np.pi * t)
    euler = np.zeros((len(frames), 3))
    euler[:, 2] = 2.0 * np.pi * t
    _animate_transforms(dragon, frames, locations=locations, euler=euler)
    bunny = models["bunny"]
    twist = bunny.modifiers.new("twist", "SIMPLE_DEFORM")
    twist.deform_method, twist.deform_axis = "TWIST", "Z"
    _animate(bunny, {('modifiers["twist"].angle', 0): BUNNY_TWIST_RAD * np.sin(2.0 * np.pi * t)}, frames)


def _sponza_camera(scene, collection, frames: np.ndarray, frame_count: int, floor_z: float) -> None:
    """One loop around the atrium on an ellipse about its centre, looking at the point of a
    half-size ellipse a quarter turn ahead: at frame 0 the camera stands at the +x end and
    looks down the atrium, past the models; half-way it looks back from the -x end. The
    model at hand is near (in the BVH), the far arcades are in the cube map."""
    angle = 2.0 * np.pi * frames / frame_count
    a, b = SPONZA_CAMERA_SEMI_AXES
    mean, amplitude = SPONZA_CAMERA_HEIGHT
    eyes = np.stack([a * np.cos(angle), SPONZA_AXIS_Y + b * np.sin(angle),
                     floor_z + mean + amplitude * np.sin(2.0 * angle)], axis=1)
    ahead = angle + np.pi / 2
    targets = np.stack([0.5 * a * np.cos(ahead), SPONZA_AXIS_Y + 0.5 * b * np.sin(ahead),
                        np.full(len(frames), floor_z + 0.9)], axis=1)
    matrices = np.stack([look_at(tuple(eye), tuple(target)) for eye, target in zip(eyes, targets)])
    _add_camera(scene, collection, "atrium camera", matrices, frames, lens=24.0, clip_start=0.05, clip_end=500.0)


def _sponza_lights(scene, collection, floor_z: float) -> None:
    _light(scene, collection, "sun", "SUN", (4.0, 3.8, 3.4), direction=(0.25, 0.15, -1.0))
    _light(scene, collection, "lamp", "POINT", (1200.0, 1050.0, 850.0),
           position=(0.0, SPONZA_AXIS_Y, floor_z + 7.0), radius=0.3)


def _build_sponza_parts(scene, assets: Path, detail: float, frame_count: int, cube_far: float):
    frames = _frames(frame_count)
    building, sponza_meshes = _import_sponza(scene, assets, cube_far)
    fallback = float(_world_bounds(sponza_meshes)[0, 2])
    floor_z = _floor_height(scene, 0.0, SPONZA_AXIS_Y, fallback)
    models = _import_models(scene, assets, detail, _new_collection(scene, "Stanford models"), floor_z, cube_far)
    _animate_models(models, frames, frame_count)
    rig = _new_collection(scene, "camera and lights")
    _sponza_lights(scene, rig, floor_z)
    _sponza_camera(scene, rig, frames, frame_count, floor_z)
    _world(scene, (0.55, 0.7, 1.0), 1.0)
    return building, sponza_meshes, models


def _build_sponza(scene, assets: Path, detail: float, frame_count: int) -> None:
    """Sponza, Buddha, bunny and dragon (see the module docstring)."""
    _, sponza_meshes, models = _build_sponza_parts(scene, assets, detail, frame_count, SPONZA_CUBE_FAR)
    # The atrium sees its sky through the roof opening: its walls and arcades hide most of
    # it at distances the screen's occlusion does not reach, so the sky (and the light the
    # sunlit floor bounces) is found by rays.
    _settings(scene, near_size=SPONZA_NEAR_SIZE, cube_far=SPONZA_CUBE_FAR, world_light="RAYS")
    total = _mesh_triangle_count(sponza_meshes) + _mesh_triangle_count(models.values())
    scene["hybrid_rt_label"] = (f"Sponza + Buddha (decimated, 100k) + bunny + dragon: {total:,} triangles "
                                f"(paper: Sponza Buddha Bunny, {PAPER_SPONZA_TRIANGLES:,})")


def large_copies(sponza_triangles: int, model_triangles: int, detail: float = 1.0) -> int:
    """Sponzas of the large scene: enough for the paper's San Miguel count at detail 1
    (with the models), a share of them below (at least two, so it stays a grid)."""
    full = math.ceil((PAPER_SAN_MIGUEL_TRIANGLES - model_triangles) / sponza_triangles)
    return max(2, min(full, round(full * detail))) if detail < 1.0 else math.ceil(full * detail)


def _build_large(scene, assets: Path, detail: float, frame_count: int) -> None:
    """A labelled stand-in for San Miguel: the sponza scene plus Sponza instances on a grid."""
    building, sponza_meshes, models = _build_sponza_parts(scene, assets, detail, frame_count, LARGE_CUBE_FAR)
    sponza_triangles = _mesh_triangle_count(sponza_meshes)
    model_triangles = _mesh_triangle_count(models.values())
    copies = large_copies(sponza_triangles, model_triangles, detail)
    # A grid of copies around the real one (slot 0, at the origin), nearest slots first.
    size = np.ptp(_world_bounds(sponza_meshes), axis=0)[:2] + LARGE_GRID_GAP_M
    side = math.ceil(math.sqrt(copies))
    half = side // 2
    slots = sorted(((i, j) for i in range(-half - 1, half + 2) for j in range(-half - 1, half + 2)),
                   key=lambda ij: (ij[0] ** 2 + ij[1] ** 2, ij))
    instances = _new_collection(scene, "Sponza copies")
    for k, (i, j) in enumerate(slots[1:copies]):
        empty = bpy.data.objects.new(f"Sponza copy {k + 1}", None)
        empty.instance_type = "COLLECTION"
        empty.instance_collection = building
        empty.location = (i * size[0], j * size[1], 0.0)
        instances.objects.link(empty)
    _settings(scene, near_size=SPONZA_NEAR_SIZE, cube_far=LARGE_CUBE_FAR)
    total = copies * sponza_triangles + model_triangles
    scene["hybrid_rt_label"] = (
        f"stand-in for San Miguel (paper: {PAPER_SAN_MIGUEL_TRIANGLES:,} triangles): {copies} copies of "
        f"Crytek Sponza + Buddha (decimated, 100k), bunny and dragon, {total:,} triangles")
    scene["hybrid_rt_sponza_copies"] = copies
    scene.name = f"large: San Miguel stand-in, {copies} x Sponza"


# ---------------------------------------------------------------------------------------
# room: a sky-lit room, the materials an artist compares engines with
# ---------------------------------------------------------------------------------------
ROOM_SIZE = (8.0, 8.0, 3.0)  # width (x), depth (y), wall height (z); open to the sky above
ROOM_SUN_ANGLE = math.radians(4.0)
ROOM_NEAR_SIZE = 10.0  # the balls and boxes in the BVH, the back wall in the cube map


def _build_room(scene, assets: Path | None, detail: float, frame_count: int) -> None:
    """Three walls and a floor under an open sky and a sun: a mirror ball, a glass ball and a
    brushed-metal ball on a glossy floor, with painted boxes; everything lit by the World
    and the sun (soft shadows from its angle). Static, seen from the open side."""
    collection = _new_collection(scene, "Room")
    width, depth, height = ROOM_SIZE
    wall = 0.2
    parts = {
        "Floor": ((-width / 2, -depth / 2, -wall), (width / 2, depth / 2, 0.0),
                  _principled("Glossy floor", (0.35, 0.33, 0.3), roughness=0.15)),
        "Back wall": ((-width / 2, depth / 2, 0.0), (width / 2, depth / 2 + wall, height),
                      _principled("Plaster", (0.8, 0.78, 0.72), roughness=0.9)),
        "Left wall": ((-width / 2 - wall, -depth / 2, 0.0), (-width / 2, depth / 2, height),
                      _principled("Red paint", (0.7, 0.12, 0.08), roughness=0.6)),
        "Right wall": ((width / 2, -depth / 2, 0.0), (width / 2 + wall, depth / 2, height),
                       _principled("Green paint", (0.15, 0.5, 0.2), roughness=0.6)),
        "Blue box": ((1.2, 1.0, 0.0), (2.4, 2.2, 1.2), _principled("Blue paint", (0.1, 0.2, 0.7), roughness=0.4)),
        "Yellow box": ((-2.8, 1.6, 0.0), (-1.8, 2.6, 2.0),
                       _principled("Yellow paint", (0.8, 0.6, 0.1), roughness=0.5)),
    }
    for name, (lo, hi, material) in parts.items():
        obj = bpy.data.objects.new(name, _box_mesh(name, lo, hi))
        obj.data.materials.append(material)
        collection.objects.link(obj)
    rings = uv_sphere_rings(max(200, int(8000 * detail)))
    balls = {
        "Mirror ball": ((-1.2, -0.2, 0.7), _principled("Mirror", (0.95, 0.95, 0.95), metallic=1.0, roughness=0.0)),
        "Glass ball": ((0.4, -1.2, 0.7), _principled("Glass", (1.0, 1.0, 1.0), transmission=1.0, roughness=0.0,
                                                     ior=1.5)),
        "Brushed metal ball": ((0.6, 1.0, 0.7), _principled("Brushed metal", (0.9, 0.7, 0.5), metallic=1.0,
                                                            roughness=0.35)),
    }
    for name, (centre, material) in balls.items():
        obj = bpy.data.objects.new(name, _uv_sphere(name, rings))
        obj.data.materials.append(material)
        obj.location = centre
        obj.scale = (0.7, 0.7, 0.7)
        collection.objects.link(obj)
    sun = _light(scene, collection, "Sun", "SUN", (3.0, 2.85, 2.6), direction=(0.35, 0.45, -0.82),
                 radius=ROOM_SUN_ANGLE)
    sun.data.angle = ROOM_SUN_ANGLE
    _world(scene, (0.45, 0.6, 0.9), 1.0)
    frames = _frames(frame_count)
    matrices = np.repeat(look_at((0.5, -9.0, 3.2), (0.0, 0.5, 0.7))[None], len(frames), axis=0)
    _add_camera(scene, collection, "Camera", matrices, frames, lens=30.0, clip_start=0.1, clip_end=100.0)
    # Light bounces between the floor, the walls and the boxes: gathered by the sky rays,
    # whose noise 16 samples of a final render smooth (the room is small: about a second each).
    _settings(scene, near_size=ROOM_NEAR_SIZE, cube_far=100.0, world_light="RAYS", render_samples=16)
    scene["hybrid_rt_label"] = "sky-lit room: mirror, glass and brushed-metal balls on a glossy floor"
    scene.name = "room: sky-lit room"


_BUILDERS = {"chess": _build_chess, "chess_real": _build_chess_real, "sponza": _build_sponza,
             "large": _build_large, "room": _build_room}


def _interior(build: Callable) -> Callable:
    """An interior (interior_scenes.py) as a library builder: static, one detail."""
    return lambda scene, assets, detail, frame_count: build(scene, assets)


_BUILDERS.update({name: _interior(build) for name, build in interior_scenes.BUILDERS.items()})


# ---------------------------------------------------------------------------------------
# Entry point
# ---------------------------------------------------------------------------------------
def build_scene(name: str, assets_dir: str | os.PathLike | None = None, detail: float = 1.0,
                frame_count: int = DEFAULT_FRAMES, resolution: tuple[int, int] = DEFAULT_RESOLUTION):
    """Build scene ``name`` (one of :data:`SCENES`) into a new Blender scene and make it the
    window's active scene; returns the ``bpy.types.Scene``.

    ``assets_dir``: the folder of third-party scenes (``../shared/scenes`` in a checkout),
    else ``$HYBRID_RT_SCENES``; unused by ``chess``. ``detail`` in (0, MAX_DETAIL]: 1 is the
    paper's size, small values give small scenes for tests (see the module docstring).
    ``frame_count``: length of the animation (frames 0 .. frame_count - 1, keyed through
    frame_count, which equals frame 0 for the periodic motions).

    Raises ``ValueError`` for a bad argument and :class:`SceneAssetError` for a missing
    file, before anything is created. Any later failure removes what was created.
    """
    if name not in _BUILDERS:
        raise ValueError(f"unknown scene {name!r}: choose one of {', '.join(SCENES)}")
    detail = float(detail)
    if not (math.isfinite(detail) and 0.0 < detail <= MAX_DETAIL):
        raise ValueError(f"detail must lie in (0, {MAX_DETAIL}], got {detail}")
    if int(frame_count) != frame_count or frame_count < 1:
        raise ValueError(f"frame_count must be a positive integer, got {frame_count!r}")
    width, height = (int(v) for v in resolution)
    if width < 1 or height < 1:
        raise ValueError(f"resolution must be at least 1 x 1, got {resolution!r}")
    if not hasattr(bpy.types.Scene, "hybrid_rt"):
        raise RuntimeError("the Hybrid RT add-on is not registered: register it before building scenes")
    assets = check_assets(name, assets_dir)

    window = bpy.context.window
    previous = window.scene if window is not None else None
    before = _id_snapshot()
    try:
        scene = bpy.data.scenes.new(name)
        if window is not None:
            window.scene = scene  # the importers add to the active scene
        scene.render.engine = "HYBRID_RT"
        scene.render.resolution_x, scene.render.resolution_y = width, height
        scene.render.resolution_percentage = 100
        scene.frame_start, scene.frame_end = 0, int(frame_count) - 1
        scene.frame_current = 0
        scene["hybrid_rt_scene"] = name
        scene["hybrid_rt_detail"] = detail
        scene["hybrid_rt_credits"] = CREDITS[name]
        _BUILDERS[name](scene, assets, detail, int(frame_count))
        scene.frame_set(0)
    except BaseException:
        _remove_created(before, previous)
        raise
    return scene
