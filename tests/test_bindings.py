# SPDX-License-Identifier: GPL-3.0-or-later
"""hybrid_engine/gpu/bindings.py: storage blocks, images, samplers and uniforms bound by name."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from hybrid_engine.gpu import bindings
from hybrid_engine.gpu import dispatch as gpu_dispatch
from hybrid_engine.gpu.bindings import Bindings, Image, Storage, bind, split_storage

SHADER_ROOT = Path(__file__).resolve().parent.parent / "gpu_shaders"

# Two storage blocks declared in the order opposite to their use, an image and two samplers of
# different types: numbers chosen by hand could swap the blocks or share a unit between the
# samplers (which makes every dispatch fail).
COPY_SHADER = """#version 430
layout(local_size_x = 1) in;
layout(std430) writeonly buffer Output { float out_values[]; };
layout(std430) readonly buffer Input { float in_values[]; };
layout(rgba32f) writeonly uniform image2D u_target;
uniform sampler2D u_flat;
uniform sampler2DArray u_layers;
uniform float u_scale;
void main() {
    uint i = gl_GlobalInvocationID.x;
    out_values[i] = in_values[i] * u_scale + texelFetch(u_flat, ivec2(0), 0).r
                    + texelFetch(u_layers, ivec3(0, 0, 1), 0).r;
    imageStore(u_target, ivec2(i, 0), vec4(float(i)));
}
"""


@pytest.fixture
def copy_program(ctx):
    prog = ctx.compute_shader(COPY_SHADER)
    yield prog
    prog.release()


def test_blocks_images_samplers_and_uniforms_reach_the_names_they_are_given(ctx, copy_program):
    values = np.arange(8, dtype=np.float32)
    src, dst = ctx.buffer(values.tobytes()), ctx.buffer(reserve=values.nbytes)
    flat = ctx.texture((1, 1), 1, np.array([100.0], np.float32).tobytes(), dtype="f4")
    layers = ctx.texture_array((1, 1, 2), 1, np.array([0.0, 1000.0], np.float32).tobytes(), dtype="f4")
    target = ctx.texture((8, 1), 4, dtype="f4")
    try:
        bind(copy_program, storage={"Input": src, "Output": dst},
             images={"u_target": Image(target, read=False, write=True)},
             textures={"u_flat": flat, "u_layers": layers}, uniforms={"u_scale": 2.0})
        copy_program.run(8)
        got = np.frombuffer(dst.read(), np.float32)
        np.testing.assert_array_equal(got, values * 2.0 + 1100.0)
        image = np.frombuffer(target.read(), np.float32).reshape(8, 4)[:, 0]
        np.testing.assert_array_equal(image, np.arange(8))
        found = bindings.layout(copy_program)
        assert sorted(found.blocks.values()) == [0, 1]
        assert sorted(found.samplers.values()) == [0, 1]  # a unit each, whatever their types
    finally:
        for obj in (src, dst, flat, layers, target):
            obj.release()


def test_a_storage_block_left_unbound_is_an_error_naming_it(ctx, copy_program):
    src = ctx.buffer(reserve=64)
    try:
        with pytest.raises(ValueError, match=r"storage block\(s\) Output not bound"):
            bind(copy_program, storage={"Input": src})
        bind(copy_program, storage={"Input": src, "Output": None})  # declared unused: accepted
    finally:
        src.release()


def test_a_storage_range_past_the_block_limit_is_refused_naming_the_block(ctx, copy_program):
    buffer = ctx.buffer(reserve=4096)
    try:
        with gpu_dispatch.forced_limits(max_block=1024):
            with pytest.raises(ValueError, match="Output: a 4096-byte range exceeds .* 1024-byte block limit"):
                bind(copy_program, storage={"Input": Storage(buffer, 1024), "Output": Storage(buffer)})
            bind(copy_program, storage={"Input": Storage(buffer, 1024), "Output": Storage(buffer, 1024, 1024)})
    finally:
        buffer.release()


def test_a_split_array_names_its_blocks_by_suffix_with_their_ranges():
    split = gpu_dispatch.BlockSplit(count=300, item_bytes=36, items_per_block=128, blocks=3)
    blocks = split_storage("TriangleInput", "buffer", split)
    assert list(blocks) == ["TriangleInput", "TriangleInput1", "TriangleInput2"]
    assert [(b.offset, b.size) for b in blocks.values()] == [(0, 128 * 36), (128 * 36, 128 * 36),
                                                             (256 * 36, 44 * 36)]


def test_parts_merge_with_the_call_s_own_names_taking_precedence():
    merged = Bindings(storage={"A": 1, "B": 2}, uniforms={"u": 1}) | Bindings(storage={"B": 3})
    assert merged.storage == {"A": 1, "B": 3} and merged.uniforms == {"u": 1}


def test_no_shader_writes_a_binding_number():
    """The host binds by name: a number in the GLSL would be a second source of truth."""
    offenders = [f"{path.relative_to(SHADER_ROOT)}:{n}" for path in SHADER_ROOT.rglob("*.glsl")
                 for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
                 if re.search(r"\bbinding\s*=", line)]
    assert offenders == []


def test_only_the_bindings_module_binds_buffers_images_and_textures_by_number():
    """Every pass binds through bindings.bind: a number chosen in a pass could collide with
    the one its program was given."""
    core = SHADER_ROOT.parent / "hybrid_engine"
    calls = re.compile(r"bind_to_storage_buffer\(|bind_to_image\(|\.use\(location|\]\.(value|write)\b")
    offenders = [f"{path.name}:{n}" for path in core.glob("*.py") if path.name != "bindings.py"
                 for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1) if calls.search(line)]
    assert offenders == []


UNIFORM_BLOCK_SHADER = """#version 430
layout(local_size_x = 1) in;
layout(std430) writeonly buffer Output { vec4 out_values[]; };
layout(std140) uniform Table { vec4 rows[4]; };
layout(std140) uniform Scale { vec4 scale; };
void main() {
    uint i = gl_GlobalInvocationID.x;
    out_values[i] = rows[i] * scale.x;
}
"""


def test_uniform_blocks_are_bound_by_name_like_storage_blocks_and_one_left_unbound_is_named(ctx):
    """Two uniform blocks (lighting.glsl's lights and shadow slots are such blocks): each
    reads the buffer named for it, and one left out is an error naming it."""
    program = ctx.compute_shader(UNIFORM_BLOCK_SHADER)
    rows = np.arange(16, dtype=np.float32)
    table, scale, out = ctx.buffer(rows.tobytes()), ctx.buffer(np.full(4, 3.0, np.float32).tobytes()), \
        ctx.buffer(reserve=64)
    try:
        with pytest.raises(ValueError, match=r"uniform block\(s\) Scale not bound"):
            bind(program, storage={"Table": table, "Output": out})
        bind(program, storage={"Scale": scale, "Table": table, "Output": out})
        program.run(4)
        np.testing.assert_array_equal(np.frombuffer(out.read(), np.float32), rows * 3.0)
    finally:
        for obj in (table, scale, out, program):
            obj.release()


def test_a_uniform_is_written_only_when_its_value_differs_from_the_last_one_written(ctx, monkeypatch):
    import _moderngl

    prog = ctx.compute_shader(COPY_SHADER)
    src, dst = ctx.buffer(np.ones(4, np.float32).tobytes()), ctx.buffer(reserve=16)
    flat = ctx.texture((1, 1), 1, np.zeros(1, np.float32).tobytes(), dtype="f4")
    layers = ctx.texture_array((1, 1, 2), 1, np.zeros(2, np.float32).tobytes(), dtype="f4")
    target = ctx.texture((4, 1), 4, dtype="f4")
    bindings.layout(prog)  # as the shader loader makes it at compile time (it sets the units)
    writes = []
    original = _moderngl.Uniform.write
    monkeypatch.setattr(_moderngl.Uniform, "write", lambda self, data: (writes.append(self.name), original(self, data)))
    try:
        parts = dict(storage={"Input": src, "Output": dst}, images={"u_target": Image(target, read=False)},
                     textures={"u_flat": flat, "u_layers": layers})
        for scale in (2.0, 2.0, 2.0, 3.0, 3.0):
            bind(prog, uniforms={"u_scale": scale}, **parts)
            prog.run(4)
            np.testing.assert_array_equal(np.frombuffer(dst.read(), np.float32), np.full(4, scale))
        assert writes == ["u_scale", "u_scale"]
        assert prog["u_scale"].value == 3.0
    finally:
        for obj in (prog, src, dst, flat, layers, target):
            obj.release()
