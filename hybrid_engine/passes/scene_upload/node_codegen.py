# SPDX-License-Identifier: GPL-3.0-or-later
"""Straight-line GLSL for node programs: one function per program *topology*, the values still
read from the words (docs/ARCHITECTURE.md "Shader node programs").

Why: the interpreter (include/node_program.glsl ``node_program_interpret``) pays, per node, a
loop step, a switch and a register file indexed by a run-time number. A dynamically indexed
local array lives in memory on llvmpipe and on GPUs alike (it cannot be kept in registers),
and that, not the nodes' arithmetic, is most of what a graph of cheap nodes costs per hit. A
function written out for the program's instruction sequence keeps every value in a named
local, and the driver sees the whole graph as straight-line code.

What makes a topology: the opcodes in order, each operand's kind (register and conversion,
inline constant and its width, shading-point value), the registers written, and where each
word sits relative to the program's first word, and the settings that change a node's
sockets in Blender (``SOCKET_SETTINGS``: Noise's dimensions and type, White Noise's
dimensions, Voronoi's dimensions, feature and metric), written as literals so that the driver
compiles only the chosen branch: llvmpipe runs both sides of an ``if`` under a mask, so a
Noise that switched on its dimensions at run time paid for all four. Such an edit changes the
node's sockets, a topology edit in Blender's sense too. What does not make a topology: the
constants' bits, the other settings, the Color Ramp and curve tables. The generated code reads
those from the ``NodeProgram`` words at the program's base, so one function serves every
material of its topology, and a value edit (even an enum such as Mix's blend type: the node
functions switch on it at run time, as the interpreter's do) is an upload of words and no
compile. A new topology is new source, hence one compile of each program that runs node
programs. The interpreter reads every setting from the words, literal here or not.

The code of each node is the interpreter's own case, taken from its switch (so the two
cannot drift apart): ``node_in[i]`` and ``node_out[o]`` with literal indices become named
locals, ``set_at`` and ``pc`` constants off the base, and ``break`` leaves a
``do { } while (false)`` around the case, and ``node_output_read(o)`` (whether a later
instruction reads output o: the interpreter looks at the output's register word) a constant
of the topology, so that the driver's compiler drops the code of an output nobody reads (a
Texture Coordinate's Generated searches the instance table), as Cycles' SVM skips it. The
Noise asks of its Color's register word at run time instead (a uniform branch; the case in
node_program.glsl says why). A case that
indexes its operands by a variable (Mix Shader's four registers) keeps small local arrays,
indexed only by unrolled loops. An
opcode without a case, or a program the walk cannot follow, gets no function: its material
runs in the interpreter, which stays compiled in unless every program has a function.

Dispatch: the word before each program (``node_program.DISPATCH_NONE`` as compiled) holds
the index of its topology's function; ``node_generated_run`` switches on it.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np

from ...gpu.shader_loader import SHADER_ROOT
from ...scene import node_codes as nc
from ...scene.node_program import CLOSURE_REGISTERS, DISPATCH_NONE, ProgramTable

INTERPRETER = SHADER_ROOT / "include" / "node_program.glsl"
MAX_INSTRUCTIONS = 256  # node_program.glsl NODE_MAX_INSTRUCTIONS
MAX_OPERANDS = 16       # NODE_MAX_OPERANDS
MAX_OUTPUTS = 8         # NODE_MAX_OUTPUTS
# Instructions written out per scene at most, over all its topologies: the compile grows with
# each, and on llvmpipe a tracer with the benchmark's 20 nodes (three textures) written out
# compiled in about 40 % of the time of one with the interpreter and four families
# (docs/BENCHMARKS.md "Shader node programs"), so past a few dozen nodes the interpreter is the
# cheaper compile. Programs of further topologies run in the interpreter (then compiled in).
MAX_GENERATED_INSTRUCTIONS = 64
# Words an instruction's case reads after its operands (the tables), by opcode.
TABLE_WORDS = {nc.OP_COLOR_RAMP: nc.RAMP_TABLE_WORDS, nc.OP_CURVE_RGB: nc.CURVE_TABLE_WORDS["CURVE_RGB"],
               nc.OP_CURVE_VECTOR: nc.CURVE_TABLE_WORDS["CURVE_VEC"],
               nc.OP_CURVE_FLOAT: nc.CURVE_TABLE_WORDS["CURVE_FLOAT"]}
_CASE_RE = re.compile(r"^\s*case\s+NODE_OP_([A-Z0-9_]+)\s*:")
_LITERAL_IN = re.compile(r"\bnode_in\[(\d+)\]")
_LITERAL_OUT = re.compile(r"\bnode_out\[(\d+)\]")
_SET_AT = re.compile(r"\bset_at\b")
_OUTPUT_READ = re.compile(r"\bnode_output_read\((\d+)\)")
_SETTING = re.compile(r"\bnode_words\[set_at(?:\s*\+\s*(\d+)u)?\]")
# Settings that change a node's sockets in Blender (its update hides or shows inputs or
# outputs), by opcode: the indices of their words. Such an edit is a topology edit in
# Blender's own sense, so the generator writes the value as a literal and the driver compiles
# only the chosen branch (llvmpipe runs both sides of an ``if`` under a mask; only loops exit
# early). Noise: ``noise_dimensions`` (W, Vector) and ``noise_type`` (Offset, Gain);
# White Noise: ``noise_dimensions``; Voronoi: ``voronoi_dimensions``, ``feature`` (its
# outputs) and ``distance`` (Minkowski's Exponent). Wave's enums and the ``normalize`` flags
# change no socket: they stay words, read at run time.
SOCKET_SETTINGS: dict[int, tuple[int, ...]] = {
    nc.OP_TEX_NOISE: (0, 1), nc.OP_TEX_WHITE_NOISE: (0,), nc.OP_TEX_VORONOI: (0, 1, 2)}


@dataclass(frozen=True)
class Case:
    """One opcode's code in the interpreter's switch: its body and the preprocessor
    conditions around it (``#ifdef NODE_FAMILY_VECTOR``...)."""

    body: str
    conditions: tuple[str, ...]


def _strip_comment(line: str) -> str:
    return line.split("//", 1)[0]


@lru_cache(maxsize=4)
def _cases_of(text: str) -> dict[int, tuple[Case, ...]]:
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.strip() == "switch (op) {")
    cases: dict[int, list[Case]] = {}
    conditions: list[str] = []
    labels: list[int] = []
    body: list[str] = []
    depth = 0

    def close() -> None:
        if labels and body:
            for op in labels:
                cases.setdefault(op, []).append(Case("\n".join(body), tuple(conditions)))
        labels.clear()
        body.clear()

    for line in lines[start + 1:]:
        stripped = line.strip()
        if depth == 0 and stripped.startswith("#"):
            close()
            word = stripped.split()[0]
            if word in ("#ifdef", "#ifndef", "#if"):
                conditions.append(stripped)
            elif word == "#else" and conditions:
                top = conditions.pop()
                rest = top.split(None, 1)[1]
                conditions.append("#ifndef " + rest if top.startswith("#ifdef")
                                  else "#ifdef " + rest if top.startswith("#ifndef") else f"#if !({rest})")
            elif word == "#endif" and conditions:
                conditions.pop()
            continue
        match = _CASE_RE.match(line) if depth == 0 else None
        if match:
            if body:
                close()
            op = nc.OPCODES.get("OP_" + match.group(1))
            if op is not None:
                labels.append(op)
            rest = line[match.end():]
            if _strip_comment(rest).strip():
                body.append(rest)
                depth += _strip_comment(rest).count("{") - _strip_comment(rest).count("}")
            continue
        if depth == 0 and stripped.startswith("default:"):
            close()
            break
        code = _strip_comment(line)
        depth += code.count("{") - code.count("}")
        if depth < 0:
            close()
            break
        if labels:
            body.append(line)
    return {op: tuple(found) for op, found in cases.items()}


def interpreter_cases(path: Path = INTERPRETER) -> dict[int, tuple[Case, ...]]:
    """The interpreter's case of each opcode (several where preprocessor branches give
    one opcode different code), read from its source."""
    return _cases_of(path.read_text(encoding="utf-8"))


@lru_cache(maxsize=None)
def _prepared(case: Case) -> tuple[bool, str, frozenset[int]]:
    """Whether ``case`` indexes its operands or outputs by a variable, its body with the
    literal indices as named locals, and the operand indices it reads."""
    dynamic = "node_in[" in _LITERAL_IN.sub("", case.body) or "node_out[" in _LITERAL_OUT.sub("", case.body)
    named = _LITERAL_OUT.sub(lambda m: f"g_out{m.group(1)}", _LITERAL_IN.sub(lambda m: f"g_in{m.group(1)}", case.body))
    return dynamic, named, frozenset(int(i) for i in _LITERAL_IN.findall(case.body))


def _operand(kind: str, value: int, conversion: int, at: int) -> str:
    """GLSL of one operand as node_operand computes it."""
    if kind == "constant":
        parts = [f"uintBitsToFloat(node_words[g_at + {at + i}u])" for i in range(value)]
        parts += ["0.0", "0.0", "0.0", "1.0"][value:]
        return f"vec4({', '.join(parts)})"
    if kind == "implicit":
        expr = ("vec4(sp.normal, 0.0)" if value == nc.IMPLICIT_NORMAL
                else "vec4(sp.uv, 0.0, 0.0)" if value == nc.IMPLICIT_UV else "vec4(node_generated(sp), 0.0)")
    else:
        expr = f"g_r{value}"
    return expr if conversion == 0 else f"node_convert({expr}, {conversion}u)"


def _outputs_read(body: str, outputs: list[int]) -> str:
    """``body`` with each ``node_output_read(o)`` the constant it is for this instruction: an
    output is read where its register is one (unread outputs hold ``NO_REGISTER``). Which
    outputs are read is part of the topology (the registers written), so no value edit
    changes it."""
    def read(match: re.Match) -> str:
        o = int(match.group(1))
        return "true" if o < len(outputs) and outputs[o] < nc.REGISTERS else "false"
    return _OUTPUT_READ.sub(read, body)


def _socket_settings(body: str, op: int, settings: list[int]) -> str:
    """``body`` with each read of a socket-changing setting (``SOCKET_SETTINGS``) the literal
    it holds in this program, so that the setting is part of the topology."""
    literal = SOCKET_SETTINGS.get(op, ())

    def read(match: re.Match) -> str:
        i = int(match.group(1) or 0)
        return f"{settings[i]}u" if i in literal and i < len(settings) else match.group(0)
    return _SETTING.sub(read, body) if literal else body


def _instruction(op: int, case_list: tuple[Case, ...], operands: list[str], outputs: list[int],
                 set_at: int, table_at: int, settings: list[int] | None = None) -> list[str]:
    """One instruction as a block: its operands into locals, its case, its outputs into
    the registers that receive them."""
    lines = ["    {"]
    n_out = min(len(outputs), MAX_OUTPUTS)
    prepared = [_prepared(c) for c in case_list]
    dynamic = any(p[0] for p in prepared)
    if dynamic:
        lines.append(f"        vec4 node_in[{MAX_OPERANDS}];")
        lines += [f"        node_in[{i}] = {expr};" for i, expr in enumerate(operands)]
        lines += [f"        node_in[{i}] = vec4(0.0);" for i in range(len(operands), MAX_OPERANDS)]
        lines.append(f"        vec4 node_out[{MAX_OUTPUTS}];")
        lines += [f"        node_out[{o}] = vec4(0.0);" for o in range(MAX_OUTPUTS)]
    else:
        lines += [f"        vec4 g_in{i} = {expr};" for i, expr in enumerate(operands)]
        used = set().union(*(p[2] for p in prepared))
        lines += [f"        vec4 g_in{i} = vec4(0.0);" for i in sorted(used) if i >= len(operands)]
        lines += [f"        vec4 g_out{o} = vec4(0.0);" for o in range(MAX_OUTPUTS)]
    lines.append(f"        const uint op = {op}u;")
    lines.append(f"        uint set_at = g_at + {set_at}u;")
    lines.append(f"        uint pc = g_at + {table_at}u;")
    for case, (_, named) in zip(case_list, ((p[0], p[1]) for p in prepared)):
        body = _socket_settings(_outputs_read(case.body if dynamic else named, outputs), op, settings or [])
        lines += list(case.conditions)
        lines.append("        do {")
        lines += body.splitlines()
        lines.append("        } while (false);")
        lines += ["#endif"] * len(case.conditions)
    for o in range(n_out):
        if outputs[o] < nc.REGISTERS:
            lines.append(f"        g_r{outputs[o]} = {'node_out[%d]' % o if dynamic else 'g_out%d' % o};")
    lines.append("    }")
    return lines


def topology_body(words: np.ndarray | list[int], offset: int, cases: dict[int, tuple[Case, ...]]) -> str | None:
    """The straight-line body of the program at ``offset`` (word offsets relative to its
    first word, ``g_at``), walked as node_program_run walks it; None where the walk meets
    an opcode without a case or leaves the words."""
    if isinstance(words, np.ndarray):
        words = words.tolist()
    pc = offset
    body: list[str] = []
    registers: set[int] = set()
    try:
        for _ in range(MAX_INSTRUCTIONS):
            header = words[pc]
            op, n_out, n_set, n_in = header & 0xFF, (header >> 8) & 0xFF, (header >> 16) & 0xFF, header >> 24
            out_at = pc + 1
            set_at = out_at + n_out
            pc = set_at + n_set
            if n_in > MAX_OPERANDS:
                return None
            operands = []
            for _i in range(n_in):
                w = words[pc]
                pc += 1
                if w & nc.CONSTANT:
                    n = min(w & 7, 4)
                    operands.append(_operand("constant", n, 0, pc - offset))
                    pc += n
                elif w & nc.IMPLICIT:
                    operands.append(_operand("implicit", w & 0xFF, (w >> 16) & 3, 0))
                else:
                    register = min(w & 0xFFFF, nc.REGISTERS - 1)
                    registers.add(register)
                    operands.append(_operand("register", register, (w >> 16) & 3, 0))
            if op == 0:
                body.append(f"    return node_closure_of(vec4[{CLOSURE_REGISTERS}]"
                            f"({', '.join(['vec4(0.0)'] * CLOSURE_REGISTERS)}), sp);")
                break
            if op == nc.OP_OUTPUT:
                result = (operands + ["vec4(0.0)"] * CLOSURE_REGISTERS)[:CLOSURE_REGISTERS]
                body.append(f"    return node_closure_of(vec4[{CLOSURE_REGISTERS}]({', '.join(result)}), sp);")
                break
            case_list = cases.get(op)
            if not case_list:
                return None
            outputs = [words[out_at + o] for o in range(min(n_out, MAX_OUTPUTS))]
            registers.update(r for r in outputs if r < nc.REGISTERS)
            settings = words[set_at:set_at + n_set]
            body += _instruction(op, case_list, operands, outputs, set_at - offset, pc - offset, settings)
            pc += TABLE_WORDS.get(op, 0)
        else:
            return None
    except IndexError:
        return None
    head = ["    ShadingPoint base = sp;"] + [f"    vec4 g_r{r} = vec4(0.0);" for r in sorted(registers)]
    return "\n".join(head + body)


@dataclass
class GeneratedPrograms:
    """A table's generated GLSL: ``source`` (for shader_loader.register_source), the topology
    index of each material (``DISPATCH_NONE``: the interpreter's), and whether every program
    has a function (then the interpreter is left out of the shaders)."""

    source: str
    dispatch: np.ndarray  # uint32 per material
    topologies: int
    complete: bool
    bodies: list[str] = field(default_factory=list)


def generate(table: ProgramTable, cases: dict[int, tuple[Case, ...]] | None = None) -> GeneratedPrograms:
    """One function per distinct topology of ``table``'s programs and the dispatcher."""
    cases = interpreter_cases() if cases is None else cases
    dispatch = np.full(len(table.offsets), DISPATCH_NONE, np.uint32)
    bodies: list[str] = []
    index_of: dict[str, int] = {}
    complete = True
    written = 0
    words = table.words.tolist()
    for m, offset in enumerate(table.offsets.tolist()):
        if offset < 0:
            continue
        body = topology_body(words, offset, cases)
        if body is None:
            complete = False
            continue
        if body not in index_of:
            size = body.count("        do {")
            if written + size > MAX_GENERATED_INSTRUCTIONS:
                complete = False
                continue
            written += size
            index_of[body] = len(bodies)
            bodies.append(body)
        dispatch[m] = index_of[body]
    out = ["// Generated from the scene's node programs (passes/scene_upload/node_codegen.py):"
           " one function per topology.", "#ifdef NODE_GENERATED"]
    for t, body in enumerate(bodies):
        out += [f"NodeClosure node_topology_{t}(uint g_at, ShadingPoint sp) {{", body, "}"]
    out += ["bool node_generated_run(int offset, ShadingPoint sp, out NodeClosure c) {",
            "    if (offset <= 0) return false;",
            "    switch (node_words[offset - 1]) {"]
    out += [f"    case {t}u: c = node_topology_{t}(uint(offset), sp); return true;" for t in range(len(bodies))]
    out += ["    default: return false;", "    }", "}", "#endif"]
    return GeneratedPrograms("\n".join(out) + "\n", dispatch, len(bodies), complete and bool(bodies), bodies)
