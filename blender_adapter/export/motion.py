# SPDX-License-Identifier: GPL-3.0-or-later
"""Motion blur's sub-frame steps: the instance table's and the camera's matrices across the
shutter, read from Blender by evaluating the scene at a few sub-frames.

Cycles evaluates an object at ``2^(motion_steps-1)*2+1`` = 3 times by default (the shutter's
opening, middle and closing) and interpolates between them (``MotionSteps``,
hybrid_engine/scene/motion.py); so does Hybrid RT. A step costs one evaluation of the
depsgraph (``RenderEngine.frame_set``) and a walk over the instances that reads matrices
only (``SceneCache.instance_matrices``), and for the meshes that evaluation deformed, their
positions and normals (``SceneCache.deformed_arrays``: same topology, as a deformed frame of
an animation is read); the frame's own evaluation is restored afterwards. A mesh whose
topology changes within the shutter keeps the frame's shape: the artist is told which.

The Vector pass (hybrid_engine/passes/film/vector.py) reads the same matrices and shapes at
the frame before and the frame after (``frame_motion``), as Cycles does when Motion Blur is
off; a mesh whose topology differs there moves rigidly, as in Cycles, without a message.
"""
from __future__ import annotations

import math

import numpy as np

from ...hybrid_engine.passes.film.vector import FRAME_TIMES
from ...hybrid_engine.scene.motion import MotionSteps, shutter_interval, step_times
from .. import messages

# Evaluations across the shutter (Cycles' default object Motion Steps of 1 gives three).
MOTION_STEPS = 3


def shutter(scene) -> tuple[float, float]:
    """The shutter's (opening, closing) in frames relative to the frame."""
    render = scene.render
    return shutter_interval(float(render.motion_blur_shutter), render.motion_blur_position)


def motion_steps(engine, depsgraph, cache, steps: int = MOTION_STEPS) -> MotionSteps | None:
    """The matrices of ``cache``'s instance table and of the scene camera at ``steps`` times
    across the shutter, or None when Motion Blur is off or the shutter is closed. ``engine``
    is the RenderEngine rendering ``depsgraph`` (its ``frame_set`` evaluates a sub-frame)."""
    scene = depsgraph.scene
    render = scene.render
    if not render.use_motion_blur or float(render.motion_blur_shutter) <= 0.0:
        return None
    times = step_times(float(render.motion_blur_shutter), render.motion_blur_position, steps)
    motion, unread = _evaluate(engine, depsgraph, cache, times)
    if unread:
        names = sorted(unread)
        shown = ", ".join(repr(n) for n in names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")
        messages.tell(f"Motion Blur does not blur a change of topology yet ({shown}): the shape is the "
                      "frame's, only the motion is blurred")
    return motion


def frame_motion(engine, depsgraph, cache) -> MotionSteps:
    """The matrices of ``cache``'s instance table and of the scene camera, and the deformed
    meshes' shapes, at the frame before, the frame and the frame after: what the Vector pass
    follows (Cycles' motion pass transforms, when Motion Blur is off)."""
    return _evaluate(engine, depsgraph, cache, np.array(FRAME_TIMES))[0]


def _evaluate(engine, depsgraph, cache, times: np.ndarray) -> tuple[MotionSteps, set[str]]:
    """The steps at ``times`` (frames relative to the frame), and the names of the meshes
    whose topology changed there; the frame's own evaluation is restored afterwards."""
    scene = depsgraph.scene
    frame, subframe = int(scene.frame_current), float(scene.frame_subframe)
    instances, cameras, shapes = [], [], []
    unread: set[str] = set()
    try:
        for offset in times:
            moment = frame + subframe + float(offset)
            whole = math.floor(moment)
            engine.frame_set(int(whole), moment - whole)
            instances.append(cache.instance_matrices(depsgraph))
            cameras.append(_camera_matrix(scene, depsgraph))
            arrays, names = cache.deformed_arrays(depsgraph)
            shapes.append(arrays)
            unread.update(names)
    finally:
        engine.frame_set(frame, subframe)
    return MotionSteps(times=times, instances=np.stack(instances), camera=np.stack(cameras),
                       deformations=_deformations(shapes, cache)), unread


def _deformations(shapes: list[dict], cache) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Per deforming mesh, its positions and normals at every step: a step whose evaluation
    did not change the mesh keeps the step before's shape (the frame's for the first)."""
    meshes = cache.scene_data.geometry.instances.meshes
    out = {}
    for index in sorted(set().union(*shapes)) if shapes else []:
        current = (meshes[index].positions, meshes[index].normals)
        positions, normals = [], []
        for arrays in shapes:
            current = arrays.get(index, current)
            positions.append(current[0])
            normals.append(current[1])
        out[index] = (np.stack(positions), np.stack(normals))
    return out


def _camera_matrix(scene, depsgraph) -> np.ndarray:
    camera = scene.camera
    if camera is None:
        return np.eye(4)
    return np.array(camera.evaluated_get(depsgraph).matrix_world, np.float64)
