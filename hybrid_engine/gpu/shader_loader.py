# SPDX-License-Identifier: GPL-3.0-or-later
"""Load GLSL passes by name from ``gpu_shaders/`` with includes, defines and a source map.

One file per pass (``lbvh/morton.comp.glsl``, ``gbuffer/gbuffer.vert.glsl``); shared code sits
in ``include/`` and is pulled in with ``#include "name.glsl"`` (guarded: each file is included
once per program, cycles are an error). The assembled source starts with ``#version``, then
the injected ``#define`` lines, then ``#line`` directives so that the driver's line numbers
can be mapped back. GLSL's ``#line`` takes a source-string number, not a file name, so the
loader keeps its own map from (string number, line) to (file, line) and rewrites compile
errors into ``file:line: message`` form.

Programs are cached per context and per (names, defines): compiling happens once per
process, never per frame.

Generated sources: ``#include "generated:NAME"`` pulls in the text that ``register_source``
returned the key of, where a program's defines set NAME to that key, and nothing where they
do not set NAME. The key is the text's hash, so the cache (keyed by the defines) compiles a
program again exactly when the text it includes changes (node programs' generated GLSL:
passes/scene_upload/node_codegen.py).
"""
from __future__ import annotations

import hashlib
import re
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

from . import bindings, gl_context

SHADER_ROOT = Path(__file__).resolve().parents[2] / "gpu_shaders"
GLSL_VERSION = "#version 430 core"
# Each file's lines are numbered from string_no * LINE_STRIDE: some drivers (Mesa) report
# source-string 0 for errors on identifiers, so the line number alone must tell the file.
LINE_STRIDE = 100_000

_INCLUDE_RE = re.compile(r'^\s*#include\s+"([^"]+)"\s*$')
GENERATED_PREFIX = "generated:"
# Generated texts by key (register_source); a handful per process, kept while it lives.
_generated: dict[str, str] = {}
# Mesa: "0:12(3): error: ..."; NVIDIA: "0(12) : error C1008: ..."; generic "ERROR: 0:12: ...".
_ERROR_LOC_RES = (
    re.compile(r"(?P<src>\d+):(?P<line>\d+)\(\d+\)"),
    re.compile(r"(?P<src>\d+)\((?P<line>\d+)\)"),
    re.compile(r"(?P<src>\d+):(?P<line>\d+)"),
)


class ShaderError(RuntimeError):
    """A shader failed to load or compile; the message names the file and line."""


@dataclass
class ShaderSource:
    """An assembled shader: the GLSL text and the map from source-string numbers to files."""

    text: str
    files: list[str] = field(default_factory=list)  # index = GLSL source-string number

    def locate(self, string_no: int, line: int) -> str:
        if line >= LINE_STRIDE:  # the line number carries the file (see LINE_STRIDE)
            string_no, line = divmod(line, LINE_STRIDE)
        if 0 <= string_no < len(self.files):
            return f"{self.files[string_no]}:{line}"
        return f"<string {string_no}>:{line}"


def shader_path(name: str | Path) -> Path:
    """The file of ``name``: a path under ``gpu_shaders/``, or an absolute ``Path`` for an
    entry shader kept elsewhere (a test's probe kernel; its includes still come from
    ``gpu_shaders/include/``)."""
    if isinstance(name, Path) and name.is_absolute():
        if not name.is_file():
            raise ShaderError(f"no shader file {name}")
        return name
    path = (SHADER_ROOT / name).resolve()
    if SHADER_ROOT not in path.parents:
        raise ShaderError(f"shader name {name!r} points outside {SHADER_ROOT}")
    if not path.is_file():
        raise ShaderError(f"no shader file {name!r} under {SHADER_ROOT}")
    return path


def register_source(text: str) -> str:
    """Keep ``text`` for ``#include "generated:NAME"`` and return its key (the value NAME
    must be defined to): the same text always has the same key."""
    key = "g" + hashlib.sha1(text.encode("utf-8")).hexdigest()[:16]
    _generated[key] = text
    return key


def _label(path: Path) -> str:
    return path.relative_to(SHADER_ROOT).as_posix() if SHADER_ROOT in path.parents else str(path)


def assemble(name: str | Path, defines: Mapping[str, object] | None = None) -> ShaderSource:
    """Resolve includes of ``name`` and prepend version and defines.

    Source string 0 is the preamble; every file gets its own string number so that
    ``#line <line> <string>`` lets the driver report where an error really is.
    """
    src = ShaderSource(text="", files=["<preamble>"])
    out: list[str] = [GLSL_VERSION]
    for key, value in sorted((defines or {}).items()):
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", key):
            raise ShaderError(f"invalid define name {key!r} for {name}")
        out.append(f"#define {key} {_glsl_value(value)}")
    string_of: dict[Path, int] = {}

    def emit(rel: str | Path, stack: tuple[Path, ...]) -> None:
        path = shader_path(rel)
        if path in stack:
            chain = " -> ".join(_label(p) for p in (*stack, path))
            raise ShaderError(f"include cycle: {chain}")
        # Each file once per program, decided by the preprocessor, not here: a file is
        # pasted at every #include inside a guard of its own, because the first #include
        # may sit in a block the preprocessor drops (#ifdef NODE_PROGRAMS ...), and a file
        # skipped here for that reason would be missing where a later #include needs it.
        string_no = string_of.get(path)
        if string_no is None:
            string_no = string_of[path] = len(src.files)
            src.files.append(_label(path))
        guard = f"HYBRID_INCLUDED_{string_no}"
        out.append(f"#ifndef {guard}")
        out.append(f"#define {guard}")
        out.append(f"#line {string_no * LINE_STRIDE + 1} {string_no}")
        for lineno, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
            if line.lstrip().startswith("#version"):
                out.append("")  # the loader owns the version line
                continue
            match = _INCLUDE_RE.match(line)
            if match and match.group(1).startswith(GENERATED_PREFIX):
                emit_generated(match.group(1)[len(GENERATED_PREFIX):])
                out.append(f"#line {string_no * LINE_STRIDE + lineno + 1} {string_no}")
                continue
            if match:
                target = match.group(1)
                if not target.startswith("include/") and "/" not in target:
                    target = "include/" + target
                emit(target, (*stack, path))
                out.append(f"#line {string_no * LINE_STRIDE + lineno + 1} {string_no}")
                continue
            out.append(line)
        out.append("#endif")

    def emit_generated(define: str) -> None:
        key = (defines or {}).get(define)
        if key is None:
            return
        text = _generated.get(str(key))
        if text is None:
            raise ShaderError(f"{name}: no generated source {key!r} for {define}")
        string_no = len(src.files)
        src.files.append(f"<generated {define}>")
        out.append(f"#line {string_no * LINE_STRIDE + 1} {string_no}")
        out.extend(text.splitlines())

    emit(name, ())
    src.text = "\n".join(out) + "\n"
    return src


def _glsl_value(value: object) -> str:
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, float):
        return repr(value)
    return str(value)


def translate_error(message: str, sources: Mapping[str, ShaderSource]) -> str:
    """Rewrite driver error locations (string:line) into file:line.

    moderngl prefixes each stage's log with the stage name ("vertex_shader"), which tells
    which source map applies to the lines that follow.
    """
    current = next(iter(sources.values()))
    lines = []
    for raw in str(message).splitlines():
        if raw.strip() in sources:
            current = sources[raw.strip()]
            lines.append(raw)
            continue
        rewritten = raw
        if "error" in raw.lower() or "warning" in raw.lower():
            for regex in _ERROR_LOC_RES:
                match = regex.search(raw)
                if match:
                    loc = current.locate(int(match.group("src")), int(match.group("line")))
                    rewritten = f"{loc}: {raw[match.end():].lstrip(' :')}"
                    break
        lines.append(rewritten)
    return "\n".join(lines)


_cache: dict[tuple, object] = {}
# Programs compiled so far (cache misses): an edit that must not compile is proved by this
# count standing still (tests/test_node_program_render.py).
compiles = 0
# Defines every program compiled inside compiled_with() gets; empty in the product.
_variant_defines: dict[str, object] = {}


@contextmanager
def compiled_with(defines: Mapping[str, object]) -> Iterator[None]:
    """Programs compiled inside the block get ``defines`` on top of their own: a build of the
    shaders with compile-time switches, compared with the plain build in one process
    (benchmarks/picture_cost.py switches the picture's features off this way). Programs are
    cached by all their defines, so a variant's are its own. Passes compile some programs
    when constructed and others on first use: construct *and* render inside the block."""
    previous = dict(_variant_defines)
    _variant_defines.update(defines)
    try:
        yield
    finally:
        _variant_defines.clear()
        _variant_defines.update(previous)


def _compile(ctx, stages: Mapping[str, str], defines: Mapping[str, object] | None):
    if _variant_defines:
        defines = {**(defines or {}), **_variant_defines}
    key = (id(ctx), tuple(sorted(stages.items())), tuple(sorted((defines or {}).items())))
    cached = _cache.get(key)
    if cached is not None:
        return cached
    global compiles
    compiles += 1
    sources = {stage: assemble(name, defines) for stage, name in stages.items()}
    try:
        if "compute_shader" in sources:
            program = ctx.compute_shader(sources["compute_shader"].text)
        else:
            program = ctx.program(**{stage: s.text for stage, s in sources.items()})
    except Exception as exc:
        names = ", ".join(str(name) for name in stages.values())
        raise ShaderError(
            f"compiling {names} failed:\n" + translate_error(str(exc), sources)
        ) from None
    program.extra = bindings.ProgramLayout.of(program, ", ".join(str(name) for name in stages.values()))
    _cache[key] = program
    return program


def compute(ctx, name: str, defines: Mapping[str, object] | None = None):
    """A cached compute shader from ``gpu_shaders/<name>``."""
    return _compile(ctx, {"compute_shader": name}, defines)


def program(
    ctx,
    vertex: str,
    fragment: str | None = None,
    geometry: str | None = None,
    defines: Mapping[str, object] | None = None,
):
    """A cached vertex(/geometry)/fragment program from ``gpu_shaders/``."""
    stages = {"vertex_shader": vertex}
    if fragment is not None:
        stages["fragment_shader"] = fragment
    if geometry is not None:
        stages["geometry_shader"] = geometry
    return _compile(ctx, stages, defines)


def clear_cache() -> None:
    """Forget cached programs (they die with their context)."""
    for prog in _cache.values():
        try:
            prog.release()
        except Exception:  # noqa: BLE001 - context may already be gone at teardown
            pass
    _cache.clear()


gl_context.on_release(clear_cache)
