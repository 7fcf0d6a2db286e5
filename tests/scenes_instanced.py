# SPDX-License-Identifier: GPL-3.0-or-later
"""A scene of instances of shared object-space meshes for the raster tests that compare the
world-space rows' draws with the instanced, indexed ones (test_gbuffer.py,
test_shadow_depth.py): several materials per mesh mapped per instance, rotated, scaled and
mirrored (uniformly and not) instances, smooth normals and UVs."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from hybrid_engine import Camera, MaterialTable, SceneData
from hybrid_engine.scene.camera import look_at
from hybrid_engine.scene.geometry import InstancedGeometry
from hybrid_engine.scene.meshes import Instances, ObjectMesh
from hybrid_engine.scene.solids import closed_outward
from scenes_analytic import quad, uv_sphere


def indexed(triangles: np.ndarray, normals: np.ndarray, uvs: np.ndarray, slots: np.ndarray,
            closed: bool) -> ObjectMesh:
    """A triangle list as the exporter stores a mesh: distinct positions and normals once."""
    positions, corner_vertices = np.unique(triangles.reshape(-1, 3), axis=0, return_inverse=True)
    unique_normals, corner_normals = np.unique(normals.reshape(-1, 3), axis=0, return_inverse=True)
    return ObjectMesh(positions=positions, corner_vertices=corner_vertices.reshape(-1),
                      normals=unique_normals, corner_normals=corner_normals.reshape(-1),
                      slots=slots, uvs=uvs.reshape(-1, 2), closed=closed)


def flat_mesh(triangles) -> ObjectMesh:
    """A triangle list as a mesh with flat normals by its winding, UVs its x and y, one slot
    (the moving-object tests' floors and boxes)."""
    triangles = np.asarray(triangles, np.float32)
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    normals = np.repeat((normals / np.linalg.norm(normals, axis=1, keepdims=True))[:, None], 3, axis=1)
    return indexed(triangles, normals.astype(np.float32), triangles[..., :2], np.zeros(len(triangles), np.int32),
                   closed=False)


def sphere_mesh() -> ObjectMesh:
    """A smooth closed sphere with UVs from its positions and two material slots in bands."""
    tris, normals = uv_sphere((0, 0, 0), 1.0, segments=20, rings=10)
    uvs = (tris[..., :2] * 0.5 + 0.5).astype(np.float32)
    slots = (np.arange(len(tris)) // 20 % 2).astype(np.int32)
    return indexed(tris, normals, uvs, slots, closed=closed_outward(tris))


def grid_mesh(cells: int = 6) -> ObjectMesh:
    """An open flat square of cells x cells quads, slots in a checkerboard, UVs its x and y."""
    tris = []
    for i in range(cells):
        for j in range(cells):
            centre = (-1 + (2 * i + 1) / cells, -1 + (2 * j + 1) / cells, 0.0)
            tris.append(quad(centre, (1 / cells, 0, 0), (0, 1 / cells, 0)))
    tris = np.concatenate(tris).astype(np.float32)
    normals = np.broadcast_to(np.float32([0, 0, 1]), tris.shape).copy()
    slots = np.repeat((np.add.outer(np.arange(cells), np.arange(cells)) % 2).reshape(-1), 2).astype(np.int32)
    return indexed(tris, normals, tris[..., :2] * 0.5 + 0.5, slots, closed=False)


def deformed(mesh: ObjectMesh, matrix: np.ndarray, version: int) -> ObjectMesh:
    """``mesh`` with its vertices and normals moved by ``matrix`` in object space: the same
    triangles (its id), version ``version``, as a deformed mesh comes from Blender (the
    moving-object tests' deforming boxes)."""
    positions = mesh.positions @ matrix[:3, :3].T + matrix[:3, 3]
    normals = mesh.normals @ np.linalg.inv(matrix[:3, :3])  # the inverse transpose, row vectors
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    return replace(mesh, positions=positions.astype(np.float32), normals=normals.astype(np.float32), version=version)


def placed(linear, offset) -> np.ndarray:
    matrix = np.eye(4)
    matrix[:3, :3] = linear
    matrix[:3, 3] = offset
    return matrix


def rotation_z(degrees: float) -> np.ndarray:
    a = np.radians(degrees)
    return np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])


def materials() -> MaterialTable:
    return MaterialTable.from_rows([
        dict(base_color=(0.8, 0.8, 0.8)),
        dict(base_color=(0.9, 0.2, 0.1), roughness=0.3),
        dict(base_color=(0.1, 0.7, 0.2), reflectivity=1.0, roughness=0.1),
        dict(base_color=(0.2, 0.3, 0.9), emission=(2.0, 1.0, 0.4)),
        dict(base_color=(0.7, 0.6, 0.1), roughness=0.8, reflectivity=0.4),
        dict(base_color=(0.3, 0.3, 0.3), roughness=0.05),
    ])


def instanced_scene() -> SceneData:
    """Four instances of a two-slot sphere (two of them mirrored, one non-uniformly) and two
    of a two-slot grid (one mirrored), each instance with its own slot materials."""
    sphere, grid = sphere_mesh(), grid_mesh()
    matrices = [placed(np.eye(3), (0, 0, 0)),
                placed(rotation_z(30) * 0.7, (2.4, 0.3, 0.1)),
                placed(np.diag([-0.8, 0.8, 0.8]), (-2.4, 0.2, 0.0)),
                placed(rotation_z(-20) @ np.diag([1.0, -1.3, 0.6]), (0.4, 2.6, 0.3)),
                placed(np.eye(3) * 5, (0, 0, -1.2)),
                placed(np.diag([2.0, -3.0, 1.0]) @ np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]]), (0, 5.5, 0.5))]
    slots = [[1, 2], [3, 1], [2, 4], [4, 3], [0, 5], [5, 0]]
    instances = Instances(meshes=[sphere, grid], mesh=np.array([0, 0, 0, 0, 1, 1]),
                          matrices=np.array(matrices, np.float32), slot_materials=[np.int32(s) for s in slots])
    assert instances.mirrored().tolist() == [False, False, True, True, False, True]
    return SceneData(geometry=InstancedGeometry(instances), materials=materials())


def camera(width: int = 160, height: int = 120) -> Camera:
    return Camera(matrix_world=look_at((1.0, -7.0, 4.0), (0.0, 1.0, 0.0)), width=width, height=height)
