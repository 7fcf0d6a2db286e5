# SPDX-License-Identifier: GPL-3.0-or-later
"""Tests for hybrid_engine/gpu/shader_loader.py: includes, defines, and errors that name file:line.

Every test writes its own tiny shader tree into a temporary directory (SHADER_ROOT is
monkeypatched) and gets a private program cache, so nothing here touches the real
``gpu_shaders/`` tree or the programs other tests have cached.
"""
from __future__ import annotations

import re
import struct
from pathlib import Path

import pytest

from hybrid_engine.gpu import shader_loader
from hybrid_engine.gpu.shader_loader import ShaderError


class ShaderTree:
    """A throw-away gpu_shaders/ directory."""

    def __init__(self, root: Path) -> None:
        self.root = root

    def write(self, name: str, text: str) -> str:
        path = self.root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
        return name


@pytest.fixture
def tree(tmp_path, monkeypatch):
    """A temporary shader root and a private program cache (released afterwards)."""
    root = (tmp_path / "gpu_shaders").resolve()
    root.mkdir()
    monkeypatch.setattr(shader_loader, "SHADER_ROOT", root)
    private_cache: dict = {}
    monkeypatch.setattr(shader_loader, "_cache", private_cache)
    yield ShaderTree(root)
    for program in private_cache.values():
        program.release()


def run_compute_int(ctx, name: str, defines=None, count: int = 1) -> list[int]:
    """Run a compute shader that writes ``count`` ints into SSBO 0; return them."""
    shader = shader_loader.compute(ctx, name, defines=defines)
    buf = ctx.buffer(reserve=4 * count)
    try:
        buf.bind_to_storage_buffer(0)
        shader.run(1)
        return list(struct.unpack(f"<{count}i", buf.read()))
    finally:
        buf.release()


COMPUTE_HEADER = (
    "layout(local_size_x = 1) in;\n"
    "layout(std430, binding = 0) writeonly buffer Out { int values[]; };\n"
)


def test_include_shared_by_two_files_is_emitted_once(ctx, tree):
    """A file included twice (directly and through another include) is compiled once.

    Without the guard the second copy would redefine ``shared_value`` and fail to compile.
    """
    tree.write("include/shared.glsl", "int shared_value() { return 7; }\n")
    tree.write("include/user.glsl", '#include "shared.glsl"\nint doubled() { return 2 * shared_value(); }\n')
    tree.write(
        "main.comp.glsl",
        COMPUTE_HEADER
        + '#include "shared.glsl"\n#include "user.glsl"\n'
        + "void main() { values[0] = shared_value() + doubled(); }\n",
    )
    assert run_compute_int(ctx, "main.comp.glsl") == [21]


def test_a_file_first_included_in_a_dropped_block_is_there_where_a_later_include_needs_it(ctx, tree):
    """The preprocessor, not the loader, decides which paste of a file counts: a file whose
    first #include sits in an #ifdef block that is dropped is still defined by the next."""
    tree.write("include/layout.glsl", "int layout_value() { return 5; }\n")
    tree.write("include/optional.glsl", '#include "layout.glsl"\nint optional_value() { return 1; }\n')
    tree.write("include/user.glsl", '#include "layout.glsl"\nint used() { return 3 * layout_value(); }\n')
    tree.write(
        "main.comp.glsl",
        COMPUTE_HEADER
        + '#ifdef WITH_OPTIONAL\n#include "optional.glsl"\n#endif\n#include "user.glsl"\n'
        + "void main() { values[0] = used(); }\n",
    )
    assert run_compute_int(ctx, "main.comp.glsl") == [15]
    assert run_compute_int(ctx, "main.comp.glsl", defines={"WITH_OPTIONAL": 1}) == [15]


def test_include_cycle_raises_naming_the_chain(tree):
    tree.write("include/a.glsl", '#include "b.glsl"\n')
    tree.write("include/b.glsl", '#include "a.glsl"\n')
    tree.write("main.comp.glsl", COMPUTE_HEADER + '#include "a.glsl"\nvoid main() {}\n')
    with pytest.raises(ShaderError) as info:
        shader_loader.assemble("main.comp.glsl")
    assert "main.comp.glsl -> include/a.glsl -> include/b.glsl -> include/a.glsl" in str(info.value)


def test_missing_include_names_the_file(tree):
    tree.write("main.comp.glsl", COMPUTE_HEADER + '#include "nowhere.glsl"\nvoid main() {}\n')
    with pytest.raises(ShaderError, match=r"include/nowhere\.glsl"):
        shader_loader.assemble("main.comp.glsl")


def test_shader_name_outside_the_root_is_refused(tree):
    with pytest.raises(ShaderError, match="outside"):
        shader_loader.assemble("../escape.comp.glsl")


def error_locations(message: str) -> set[str]:
    """The ``file:line`` locations at the start of the lines of a translated compile log."""
    return set(re.findall(r"^([\w./<>-]+:\d+): ", message, flags=re.MULTILINE))


def test_compile_error_in_entry_file_names_file_and_line(ctx, tree):
    """Line numbers count from the entry file's first line, also after an include and defines."""
    tree.write("include/helper.glsl", "int helper() {\n    return 1;\n}\n")
    tree.write(
        "broken.comp.glsl",
        COMPUTE_HEADER                                   # lines 1-2
        + '#include "helper.glsl"\n'                      # line 3
        + "void main() {\n"                               # line 4
        + "    values[0] = helper() + no_such_name;\n"    # line 5: the error
        + "}\n",
    )
    with pytest.raises(ShaderError) as info:
        shader_loader.compute(ctx, "broken.comp.glsl", defines={"UNUSED_A": 1, "UNUSED_B": 2})
    assert error_locations(str(info.value)) == {"broken.comp.glsl:5"}, str(info.value)


def test_compile_error_inside_included_file_names_that_file(ctx, tree):
    tree.write("include/faulty.glsl", "// a comment line\nfloat faulty() {\n    return missing_value;\n}\n")
    tree.write(
        "user.comp.glsl",
        COMPUTE_HEADER + '#include "faulty.glsl"\nvoid main() { values[0] = int(faulty()); }\n',
    )
    with pytest.raises(ShaderError) as info:
        shader_loader.compute(ctx, "user.comp.glsl")
    message = str(info.value)
    assert "user.comp.glsl" in message  # which program failed
    assert error_locations(message) == {"include/faulty.glsl:3"}, message


def test_vertex_fragment_error_names_the_stage_file(ctx, tree):
    """In a two-stage program the location is mapped with the failing stage's own source map."""
    tree.write("quad.vert.glsl", "in vec2 in_pos;\nvoid main() { gl_Position = vec4(in_pos, 0.0, 1.0); }\n")
    tree.write("quad.frag.glsl", "out vec4 colour;\nvoid main() {\n    colour = vec4(undeclared);\n}\n")
    with pytest.raises(ShaderError) as info:
        shader_loader.program(ctx, vertex="quad.vert.glsl", fragment="quad.frag.glsl")
    assert error_locations(str(info.value)) == {"quad.frag.glsl:3"}, str(info.value)


def test_defines_are_injected_with_glsl_spelling(ctx, tree):
    """Integers, booleans (1/0) and floats reach the shader with the values given."""
    tree.write(
        "defines.comp.glsl",
        COMPUTE_HEADER
        + "void main() {\n"
        + "    values[0] = COUNT;\n"
        + "    values[1] = FLAG_ON;\n"
        + "    values[2] = FLAG_OFF;\n"
        + "    values[3] = int(SCALE * 4.0);\n"
        + "}\n",
    )
    defines = {"COUNT": 257, "FLAG_ON": True, "FLAG_OFF": False, "SCALE": 2.5}
    assert run_compute_int(ctx, "defines.comp.glsl", defines=defines, count=4) == [257, 1, 0, 10]
    # Other values make another program, not a stale cached one.
    defines2 = {"COUNT": 3, "FLAG_ON": True, "FLAG_OFF": False, "SCALE": 0.25}
    assert run_compute_int(ctx, "defines.comp.glsl", defines=defines2, count=4) == [3, 1, 0, 1]


def test_invalid_define_name_is_refused(tree):
    tree.write("main.comp.glsl", COMPUTE_HEADER + "void main() {}\n")
    with pytest.raises(ShaderError, match="invalid define name"):
        shader_loader.assemble("main.comp.glsl", defines={"NOT VALID": 1})


def test_version_line_in_a_file_is_replaced_by_the_loaders(ctx, tree):
    """The loader owns ``#version``: a file's own version line must not reach the driver twice."""
    tree.write("versioned.comp.glsl", "#version 450\n" + COMPUTE_HEADER + "void main() { values[0] = 5; }\n")
    text = shader_loader.assemble("versioned.comp.glsl").text
    assert [line for line in text.splitlines() if line.startswith("#version")] == [shader_loader.GLSL_VERSION]
    assert run_compute_int(ctx, "versioned.comp.glsl") == [5]


def test_programs_are_cached_per_name_and_defines(ctx, tree):
    tree.write("cached.comp.glsl", COMPUTE_HEADER + "void main() { values[0] = N; }\n")
    first = shader_loader.compute(ctx, "cached.comp.glsl", defines={"N": 1})
    assert shader_loader.compute(ctx, "cached.comp.glsl", defines={"N": 1}) is first
    assert shader_loader.compute(ctx, "cached.comp.glsl", defines={"N": 2}) is not first
