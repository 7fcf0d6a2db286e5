# SPDX-License-Identifier: GPL-3.0-or-later
"""Cycles' Vector pass (hybrid_engine/passes/film/vector.py): the motion of what each pixel
sees towards the previous frame (xy) and from the next (zw), in pixels, as Cycles writes it
when Motion Blur is off, and present but 0 when it is on."""
from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.lib.stride_tricks import sliding_window_view

from hybrid_engine import RenderSettings
from hybrid_engine.frame.antialias import render_antialiased
from hybrid_engine.frame.film import FrameOutputs
from hybrid_engine.frame.renderer import Renderer
from hybrid_engine.passes.film.vector import FRAME_TIMES, VectorRequest
from hybrid_engine.scene.camera import Camera, look_at
from hybrid_engine.scene.motion import MotionSteps

CHANNELS = "XYZW"


def build_motion_scene(bpy, *, cube_moves: bool = True, camera_pans: bool = False, blur: bool = False):
    """A still floor and a unit cube, seen at frame 2 of a linear animation: the cube moves
    0.2 right and 0.05 away per frame, the camera turns 2 degrees left per frame."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=40, location=(0, 0, -1))
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0, 0, 0))
    cube = bpy.context.object
    if cube_moves:
        cube.location = (-0.2, -0.05, 0)
        cube.keyframe_insert("location", frame=1)
        cube.location = (0.2, 0.05, 0)
        cube.keyframe_insert("location", frame=3)
    camera = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    scene.collection.objects.link(camera)
    scene.camera = camera
    camera.location, camera.rotation_euler = (0, -6, 2), (math.radians(72), 0, 0)
    if camera_pans:
        camera.keyframe_insert("rotation_euler", frame=1)
        camera.rotation_euler = (math.radians(72), 0, math.radians(4))
        camera.keyframe_insert("rotation_euler", frame=3)
    for obj in (cube, camera):
        if obj.animation_data is not None:
            _linear(obj.animation_data.action)
    scene.frame_set(2)
    scene.render.resolution_x, scene.render.resolution_y = 64, 48
    scene.render.resolution_percentage = 100
    scene.render.use_motion_blur = blur
    scene.view_layers[0].use_pass_vector = True
    scene.cycles.samples, scene.cycles.device = 16, "CPU"
    scene.hybrid_rt.mode, scene.hybrid_rt.render_samples = "RASTER", 4
    return scene


def _linear(action) -> None:
    """Linear keys: the motion between frames 1 and 3 is the same on both sides of frame 2."""
    curves = getattr(action, "fcurves", None)
    if curves is None:  # Blender 4.4+: layered actions
        curves = [c for layer in action.layers for strip in layer.strips for bag in strip.channelbags
                  for c in bag.fcurves]
    for curve in curves:
        for key in curve.keyframe_points:
            key.interpolation = "LINEAR"


def render_vector(bpy, scene, engine: str, path) -> np.ndarray:
    """``engine``'s Vector pass of ``scene`` as (H, W, 4), row 0 at the bottom."""
    from test_engine import render_multilayer

    scene.render.engine = engine
    channels = render_multilayer(bpy, scene, path)
    return np.stack([channels[f"ViewLayer.Vector.{c}"] for c in CHANNELS], axis=-1)


def interior(mask: np.ndarray) -> np.ndarray:
    """The pixels of ``mask`` whose eight neighbours are in it too: away from the edges,
    where Cycles' wider pixel filter and its count of samples decide the mixture."""
    return sliding_window_view(np.pad(mask, 1), (3, 3)).all(axis=(-1, -2))


def test_a_translating_cube_moves_as_in_cycles_and_the_still_floor_is_zero(addon, tmp_path):
    import bpy

    scene = build_motion_scene(bpy)
    cycles = render_vector(bpy, scene, "CYCLES", tmp_path / "cycles.exr")
    ours = render_vector(bpy, scene, "HYBRID_RT", tmp_path / "ours.exr")
    moving = interior(np.abs(cycles[..., 0]) > 1.0)
    assert moving.sum() > 100
    # The cube was left of here a frame ago and will be right of here: Cycles' signs.
    assert (cycles[moving][:, [0, 2]] < -2.0).all()
    assert np.abs(ours - cycles)[moving].mean(axis=0).max() < 0.1, (ours[moving].mean(0), cycles[moving].mean(0))
    still = interior(np.abs(cycles).max(axis=-1) == 0.0)
    assert still.sum() > 1000
    assert np.abs(ours[still]).max() == 0.0


def test_a_camera_pan_moves_the_still_scene_as_in_cycles(addon, tmp_path):
    import bpy

    scene = build_motion_scene(bpy, cube_moves=False, camera_pans=True)
    cycles = render_vector(bpy, scene, "CYCLES", tmp_path / "cycles.exr")
    ours = render_vector(bpy, scene, "HYBRID_RT", tmp_path / "ours.exr")
    seen = interior(np.abs(cycles).max(axis=-1) > 0.0)
    assert seen.sum() > 1000
    # Turning left, the camera saw the floor further right a frame ago (it moves left on screen).
    assert cycles[seen][:, 0].mean() < -2.0
    assert np.abs(ours - cycles)[seen].mean(axis=0).max() < 0.1, (ours[seen].mean(0), cycles[seen].mean(0))
    assert np.abs(ours - cycles)[seen].max() < 1.0


def test_a_shape_key_deforming_the_cube_moves_its_pixels_as_in_cycles(addon, tmp_path):
    """The cube's matrix stays; a shape key leans its top 0.3 right per frame: the motion is
    the vertices' (deformation motion), as Cycles reads it."""
    import bpy

    scene = build_motion_scene(bpy, cube_moves=False)
    cube = bpy.data.objects["Cube"]
    cube.shape_key_add(name="Basis")
    lean = cube.shape_key_add(name="Lean")
    for point in lean.data:
        if point.co.z > 0:
            point.co.x += 0.6
    lean.value = 0.0
    lean.keyframe_insert("value", frame=1)
    lean.value = 1.0
    lean.keyframe_insert("value", frame=3)
    _linear(cube.data.shape_keys.animation_data.action)
    scene.frame_set(2)
    cycles = render_vector(bpy, scene, "CYCLES", tmp_path / "cycles.exr")
    ours = render_vector(bpy, scene, "HYBRID_RT", tmp_path / "ours.exr")
    moving = interior(np.abs(cycles[..., 0]) > 0.5)
    assert moving.sum() > 100
    assert cycles[moving][:, 0].mean() < -2.0
    assert np.abs(ours - cycles)[moving].mean(axis=0).max() < 0.1, (ours[moving].mean(0), cycles[moving].mean(0))


def test_with_motion_blur_on_the_vector_pass_is_there_and_zero_as_in_cycles(addon, tmp_path):
    import bpy

    scene = build_motion_scene(bpy, camera_pans=True, blur=True)
    cycles = render_vector(bpy, scene, "CYCLES", tmp_path / "cycles.exr")
    ours = render_vector(bpy, scene, "HYBRID_RT", tmp_path / "ours.exr")
    assert not cycles.any()
    assert not ours.any()
    scene.render.use_motion_blur = False  # the same scene moves: the pass is not 0 for want of motion
    assert np.abs(render_vector(bpy, scene, "HYBRID_RT", tmp_path / "still.exr")).max() > 2.0


def test_the_compositors_vector_blur_smears_the_moving_cube_along_our_vector_pass(addon, tmp_path):
    """The compositor reads the pass: Vector Blur (Image, Speed from Vector, Z from Depth)
    smears the glowing cube sideways, along its motion, and not up or down."""
    import bpy
    from test_engine import render_multilayer

    scene = build_motion_scene(bpy)
    scene.view_layers[0].use_pass_z = True
    glow = bpy.data.materials.new("glow")
    bsdf = glow.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Emission Color"].default_value = (1, 1, 1, 1)
    bsdf.inputs["Emission Strength"].default_value = 5.0
    bpy.data.objects["Cube"].data.materials.append(glow)
    tree = bpy.data.node_groups.new("Blur", "CompositorNodeTree")
    scene.compositing_node_group = tree
    tree.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor")
    layers, output = tree.nodes.new("CompositorNodeRLayers"), tree.nodes.new("NodeGroupOutput")
    blur = tree.nodes.new("CompositorNodeVecBlur")
    tree.links.new(layers.outputs["Image"], blur.inputs["Image"])
    tree.links.new(layers.outputs["Vector"], blur.inputs["Speed"])
    tree.links.new(layers.outputs["Depth"], blur.inputs["Z"])
    blur.inputs["Shutter"].default_value = 2.0  # a frame either way: about 3 pixels each side
    tree.links.new(blur.outputs[0], output.inputs["Image"])
    scene.render.engine = "HYBRID_RT"
    channels = render_multilayer(bpy, scene, tmp_path / "blurred.exr")

    def extent(layer: str) -> tuple[int, int]:
        """The glow's width and height in pixels."""
        lit = np.stack([channels[f"{layer}.Combined.{c}"] for c in "RGB"], axis=-1).mean(axis=-1) > 0.1
        rows, columns = np.nonzero(lit)
        return int(columns.max() - columns.min() + 1), int(rows.max() - rows.min() + 1)

    sharp, smeared = extent("ViewLayer"), extent("Composite")
    assert sharp[0] > 8
    assert smeared[0] >= sharp[0] + 4, (sharp, smeared)
    assert abs(smeared[1] - sharp[1]) <= 1, (sharp, smeared)


def test_the_vector_switch_adds_the_render_layers_socket_and_the_passes_panel_offers_it(addon):
    import bpy
    from test_properties import RecordingLayout

    scene = bpy.context.scene
    scene.render.engine = "HYBRID_RT"
    layer = scene.view_layers[0]
    tree = bpy.data.node_groups.new("Sockets", "CompositorNodeTree")
    scene.compositing_node_group = tree
    node = tree.nodes.new("CompositorNodeRLayers")

    def shown() -> bool:
        return "Vector" in node.outputs and node.outputs["Vector"].enabled

    layer.use_pass_vector = False
    bpy.context.view_layer.update()
    assert not shown()
    layer.use_pass_vector = True
    bpy.context.view_layer.update()
    assert shown()

    drawn: list[str] = []

    class FakeContext:
        view_layer = layer

    class FakePanel:
        layout = RecordingLayout(drawn)

    addon.ui.panels.VIEWLAYER_PT_hybrid_rt_passes.draw(FakePanel(), FakeContext)
    assert "use_pass_vector" in drawn


# -- the core, without Blender ------------------------------------------------------------------

def _box_scene(box_alpha: float = 1.0, program: bool = False):
    """A box before a wall; ``program``: the box's alpha is its graph's (a Value node into
    the Principled's Alpha: an alpha program, closure_alpha.py), not its row's."""
    from hybrid_engine.scene.data import Lights, MaterialTable, SceneData, Sky
    from hybrid_engine.scene.geometry import Geometry, InstancedGeometry
    from hybrid_engine.scene.shader_graph import Link, ShaderGraph
    from scenes_analytic import box

    flat = Geometry.from_objects([(box((-0.3, -0.3, -0.3), (0.3, 0.3, 0.3)), None, 0),
                                  (box((-3.0, 2.0, -3.0), (3.0, 2.2, 3.0)), None, 1)])  # a wall behind
    materials = MaterialTable.from_rows([{"base_color": (1, 1, 1), "alpha": 1.0 if program else box_alpha},
                                         {"base_color": (1, 1, 1)}])
    if program:
        graph = ShaderGraph()
        value = graph.add("VALUE", Value=box_alpha)
        graph.surface = Link(graph.add("BSDF_PRINCIPLED", Alpha=Link(value, "Value")), "BSDF")
        materials.node_graphs = [graph, None]
    return SceneData(geometry=InstancedGeometry.from_world(flat), materials=materials, lights=Lights.empty(),
                     sky=Sky(color=(0, 0, 0)))


def _project(camera: Camera, point) -> np.ndarray:
    clip = camera.view_projection() @ np.append(np.asarray(point, np.float64), 1.0)
    return (clip[:2] / clip[3] * 0.5 + 0.5) * np.array([camera.width, camera.height])


def _render(gl, scene, camera, motion, samples=2) -> np.ndarray:
    renderer = Renderer(gl)
    try:
        result = render_antialiased(renderer, scene, camera, RenderSettings(mode="RASTER", shadow_resolution=256),
                                    samples, outputs=FrameOutputs(vector=VectorRequest(motion)))
    finally:
        renderer.release()
    return result.data_passes["Vector"]


def test_a_deforming_mesh_moves_with_its_vertices_not_its_matrix(gl):
    """The box's matrix stays, its vertices move: the pass follows the vertices (Cycles'
    deformation motion), each corner of the front face projected at the other frames."""
    scene = _box_scene()
    camera = Camera(matrix_world=look_at((0.0, -6.0, 0.0), (0.0, 0.0, 0.0)), width=64, height=32)
    instances = scene.geometry.instances
    still = np.stack([instances.matrices.astype(np.float64)] * 3)
    mesh = instances.meshes[int(instances.mesh[0])]
    shift = np.array([0.25, 0.0, 0.1], np.float32)
    positions = np.stack([mesh.positions - shift, mesh.positions, mesh.positions + 2 * shift])
    normals = np.stack([mesh.normals] * 3)
    motion = MotionSteps(times=FRAME_TIMES, instances=still, camera=np.stack([camera.matrix_world] * 3),
                         deformations={int(instances.mesh[0]): (positions, normals)})
    vector = _render(gl, scene, camera, motion)
    front = (0.0, -0.3, 0.0)  # the front face's centre
    expected_previous = _project(camera, np.array(front) - shift) - _project(camera, front)
    expected_next = _project(camera, front) - _project(camera, np.array(front) + 2 * shift)
    centre = vector[15:17, 31:33].reshape(-1, 4).mean(axis=0)
    assert np.allclose(centre[:2], expected_previous, atol=0.02), (centre, expected_previous)
    assert np.allclose(centre[2:], expected_next, atol=0.02), (centre, expected_next)
    assert np.abs(vector[2:6, 2:10]).max() == 0.0  # the wall stays


def test_a_turning_instance_moves_each_pixel_by_its_own_point_not_its_centre(gl):
    """A box turning about its vertical axis: its front face's left and right halves move
    in opposite depth and the pass gives each point's own image at the other frames."""
    scene = _box_scene()
    camera = Camera(matrix_world=look_at((0.0, -6.0, 0.0), (0.0, 0.0, 0.0)), width=64, height=32)
    current = scene.geometry.instances.matrices.astype(np.float64)
    angle = math.radians(10.0)
    turn = np.eye(4)
    turn[:2, :2] = [[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]]
    previous, following = current.copy(), current.copy()
    previous[0] = turn.T @ current[0]
    following[0] = turn @ current[0]
    motion = MotionSteps(times=FRAME_TIMES, instances=np.stack([previous, current, following]),
                         camera=np.stack([camera.matrix_world] * 3))
    vector = _render(gl, scene, camera, motion)
    # The point of the front face seen at pixel (x, row 16): where the view ray meets y = -0.3.
    inverse = np.linalg.inv(camera.view_projection())
    for x in (29, 34):
        ndc = np.array([(x + 0.5) / 32.0 - 1.0, (16 + 0.5) / 16.0 - 1.0])
        near, far = (inverse @ np.array([*ndc, z, 1.0]) for z in (-1.0, 1.0))
        near, far = near[:3] / near[3], far[:3] / far[3]
        point = near + (far - near) * ((-0.3 - near[1]) / (far[1] - near[1]))
        here = _project(camera, point)
        before = _project(camera, turn.T[:3, :3] @ point)
        after = _project(camera, turn[:3, :3] @ point)
        assert np.allclose(vector[16, x], [*(before - here), *(here - after)], atol=0.05), (x, vector[16, x])


@pytest.mark.parametrize("program", [False, True], ids=["row", "program"])
@pytest.mark.parametrize("alpha", [0.0, 0.5])
def test_a_box_with_alpha_moves_its_pixels_as_often_as_the_g_buffer_sees_it(gl, alpha, program):
    """Alpha is coverage (include/alpha.glsl): a sample sees the moving box's front face with
    probability alpha, else its back face with alpha again (further away: it moves fewer
    pixels), else the still wall; the pass is the mean over the samples (Cycles averages
    over every sample that hits). The row's alpha and a graph's alpha program alike."""
    scene = _box_scene(box_alpha=alpha, program=program)
    camera = Camera(matrix_world=look_at((0.0, -6.0, 0.0), (0.0, 0.0, 0.0)), width=64, height=32)
    current = scene.geometry.instances.matrices.astype(np.float64)
    previous, following = current.copy(), current.copy()
    previous[0, 0, 3] -= 0.3
    following[0, 0, 3] += 0.3
    motion = MotionSteps(times=FRAME_TIMES, instances=np.stack([previous, current, following]),
                         camera=np.stack([camera.matrix_world] * 3))
    vector = _render(gl, scene, camera, motion, samples=16)
    front = _project(camera, (0.3, -0.3, 0.0))[0] - _project(camera, (0.0, -0.3, 0.0))[0]
    back = _project(camera, (0.3, 0.3, 0.0))[0] - _project(camera, (0.0, 0.3, 0.0))[0]
    expected = -(alpha * front + (1.0 - alpha) * alpha * back)
    assert abs(vector[13:19, 29:35, 0].mean() - expected) < 0.08 * front, (vector[13:19, 29:35, 0].mean(), expected)


def test_a_frame_without_a_vector_request_plans_no_vector_pass(gl):
    renderer = Renderer(gl)
    try:
        names = [p.name for p in renderer.passes(RenderSettings(mode="HYBRID"), accumulate=True)]
        assert "vector" not in names
        assert renderer.vector is None
        names = [p.name for p in renderer.passes(RenderSettings(mode="HYBRID"), accumulate=True, vector=True)]
        assert names[-1] == "vector"
    finally:
        renderer.release()


def test_a_request_needs_the_frames_before_and_after():
    camera = np.stack([np.eye(4)] * 2)
    with pytest.raises(ValueError, match="frames"):
        VectorRequest(MotionSteps(times=[-0.5, 0.5], instances=np.zeros((2, 0, 4, 4)), camera=camera))
