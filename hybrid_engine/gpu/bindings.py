# SPDX-License-Identifier: GPL-3.0-or-later
"""Binding buffers, images, textures and uniforms to a program by name.

The GLSL declares its storage and uniform blocks, images and samplers without binding
numbers; the host names what goes where (``{"BVHNodes": built.nodes}``: a buffer by its
block's name, whichever kind of block the GLSL declares), and this module picks the numbers
from moderngl's reflection of the program. No binding number is written in both languages, so a
pass cannot bind a buffer to another block's number, and a block a pass forgot to bind is
an error naming it rather than a read of whatever the last pass left bound.

Each program's numbers are fixed once, when it is compiled (stored in ``program.extra``):
a storage or uniform block gets the binding point of its own resource index, each image and
sampler a unit of its own. Later calls only bind the buffers and textures.

A name the program does not have is skipped: the compiler drops blocks and uniforms a
variant never reads (``#if`` branches, unused inputs), and callers pass what the pass may
need. A storage block given as None is declared unused by this dispatch and left unbound.
"""
from __future__ import annotations

import struct
from dataclasses import dataclass, field
from typing import Mapping

import moderngl

from .dispatch import BlockSplit, max_block_bytes


@dataclass(frozen=True)
class Storage:
    """``size`` bytes of ``buffer`` from ``offset`` (to its end when None) as one block,
    checked against the driver's block-size limit. A plain buffer is bound whole, unchecked:
    small tables (materials, lights) whose grow-only buffers may be larger than their rows."""

    buffer: object
    size: int | None = None
    offset: int = 0


@dataclass(frozen=True)
class Image:
    """A texture level bound as an image (imageLoad / imageStore)."""

    texture: object
    read: bool = True
    write: bool = True
    level: int = 0


@dataclass(frozen=True)
class Bindings:
    """What an owner of GPU data (the scene, the frame's lighting) hands to every pass that
    reads it: storage blocks, images, samplers and uniforms by name. ``a | b`` merges."""

    storage: Mapping[str, object] = field(default_factory=dict)
    images: Mapping[str, Image] = field(default_factory=dict)
    textures: Mapping[str, object] = field(default_factory=dict)
    uniforms: Mapping[str, object] = field(default_factory=dict)

    def __or__(self, other: "Bindings") -> "Bindings":
        return Bindings({**self.storage, **other.storage}, {**self.images, **other.images},
                        {**self.textures, **other.textures}, {**self.uniforms, **other.uniforms})


def split_storage(name: str, buffer, split: BlockSplit) -> dict[str, Storage]:
    """The blocks of an array bound as ``split`` (gpu_dispatch.split_blocks): block 0 is
    ``name``, block k > 0 is ``name`` + k (storage_blocks.glsl)."""
    return {name if block == 0 else f"{name}{block}": Storage(buffer, size, offset)
            for block, (offset, size) in enumerate(split.ranges())}


def _is_image(gl_type: int) -> bool:
    return 0x904C <= gl_type <= 0x906C  # GL_IMAGE_1D .. GL_UNSIGNED_INT_IMAGE_2D_MULTISAMPLE_ARRAY


def _is_sampler(gl_type: int) -> bool:
    return (0x8B5D <= gl_type <= 0x8B64  # GL_SAMPLER_1D .. GL_SAMPLER_2D_RECT_SHADOW
            or 0x8DC0 <= gl_type <= 0x8DD8  # array, cube-shadow, buffer and integer samplers
            or 0x9108 <= gl_type <= 0x910D  # multisample samplers
            or 0x900C <= gl_type <= 0x900F)  # cube-map arrays


@dataclass
class ProgramLayout:
    """A program's storage and uniform blocks (name → binding point) and its image and
    sampler units (name → unit), fixed once per program."""

    label: str
    blocks: dict[str, int]
    images: dict[str, int]
    samplers: dict[str, int]
    uniform_blocks: dict[str, int] = field(default_factory=dict)
    # The program's uniforms by name (what the compiler kept), the bytes last written to each
    # and the value they were made from. A program keeps its uniforms' values across draws
    # and frames (GL state per program), so a value equal to the last one written needs no
    # write: most of a frame's uniforms (lamps, settings, the cube map's faces) are the same
    # from frame to frame, and a pass hands many more names than one program reads.
    uniforms: dict[str, object] = field(default_factory=dict, repr=False)
    written: dict[str, bytes] = field(default_factory=dict, repr=False)
    raw: dict[str, object] = field(default_factory=dict, repr=False)

    @classmethod
    def of(cls, program, label: str = "program") -> "ProgramLayout":
        """Give every storage and uniform block the binding point of its resource index and
        every image and sampler its own unit, in declaration order. Two samplers of different types on
        one unit would make every dispatch fail, so each gets one even if never bound."""
        blocks, images, samplers, uniform_blocks, uniforms = {}, {}, {}, {}, {}
        for name in program:
            member = program[name]
            if isinstance(member, moderngl.Uniform):
                uniforms[name] = member
            if isinstance(member, moderngl.StorageBlock):
                member.binding = member.index
                blocks[name] = member.index
            elif isinstance(member, moderngl.UniformBlock):
                member.binding = member.index
                uniform_blocks[name] = member.index
            elif isinstance(member, moderngl.Uniform) and _is_image(member.gl_type):
                images[name] = member.value = len(images)
            elif isinstance(member, moderngl.Uniform) and _is_sampler(member.gl_type):
                samplers[name] = member.value = len(samplers)
        return cls(label, blocks, images, samplers, uniform_blocks, uniforms)


def layout(program, label: str | None = None) -> ProgramLayout:
    """``program``'s binding layout, made on first use (shader_loader makes it at compile
    time with the shader's file names as label)."""
    found = program.extra
    if not isinstance(found, ProgramLayout):
        found = program.extra = ProgramLayout.of(program, label or "program")
    return found


def uniform_bytes(member, value) -> bytes:
    """The bytes moderngl's ``Uniform.value`` setter writes for ``value`` (``bytes`` as they
    are), so that a write can be compared with the last one before it is made."""
    if isinstance(value, bytes):
        return value
    if member.array_length > 1:
        if member.dimension > 1:
            return b"".join(struct.pack(member.fmt, *row) for row in value)
        return b"".join(struct.pack(member.fmt, item) for item in value)
    if member.dimension > 1:
        return struct.pack(member.fmt, *value)
    return struct.pack(member.fmt, value)


_ABSENT = object()


def set_uniforms(program, values: Mapping[str, object]) -> None:
    """Set the uniforms the compiler kept (unused ones are optimised away and absent);
    ``bytes`` values are written raw (matrices and arrays). A program with a layout
    (every program the shader loader compiles) skips the writes of values equal to the
    ones it last wrote: the GL keeps them, and the host's per-frame cost then follows
    what changed rather than how many uniforms the passes set."""
    found = program.extra
    if not isinstance(found, ProgramLayout):
        for name, value in values.items():
            member = program.get(name, None)
            if member is not None:
                member.write(uniform_bytes(member, value))
        return
    _set_layout_uniforms(found, (values,))


# Values whose identity with the last one written proves them equal (immutable).
_IMMUTABLE = (bytes, int, float, bool)


def _set_layout_uniforms(found: ProgramLayout, tables) -> None:
    """Each of the program's uniforms that ``tables`` name (the first table that has it
    wins), written only when its bytes differ from the last written."""
    written, raw = found.written, found.raw
    for name, member in found.uniforms.items():
        value = _first(tables, name)
        if value is _ABSENT:
            continue
        if value is raw.get(name, _ABSENT) and type(value) in _IMMUTABLE:
            continue  # the very value last written
        data = uniform_bytes(member, value)
        if written.get(name) != data:
            member.write(data)
            written[name] = data
        raw[name] = value


def bind(program, *parts: Bindings, storage: Mapping[str, object] | None = None,
         images: Mapping[str, Image] | None = None, textures: Mapping[str, object] | None = None,
         uniforms: Mapping[str, object] | None = None) -> None:
    """Bind everything one dispatch or draw of ``program`` reads and writes, by name: the
    ``parts`` handed over by the data's owners, then ``storage`` blocks (a buffer, a
    :class:`Storage` range, or None for a block this dispatch does not touch), ``images``,
    ``textures`` (samplers) and ``uniforms``. Raises ValueError naming the program and the
    blocks when one of its storage blocks is missing, or when a range exceeds the driver's
    block-size limit."""
    # The program's own names are looked up in the call's names, then in the parts in turn
    # (the first that has a name wins, as ``part | call`` merges them): a pass hands over
    # every table the frame owns, and merging them all into new dictionaries per dispatch
    # cost more than the few names a program declares.
    found = layout(program)
    storages = (storage or _NOTHING, *(part.storage for part in parts))
    uniform_blocks = [(name, point, _first(storages, name)) for name, point in found.uniform_blocks.items()]
    blocks = [(name, point, _first(storages, name)) for name, point in found.blocks.items()]
    for kind, chosen in (("storage", blocks), ("uniform", uniform_blocks)):
        missing = [name for name, _, what in chosen if what is _ABSENT]
        if missing:
            raise ValueError(f"{found.label}: {kind} block(s) {', '.join(missing)} not bound")
    for _, point, what in uniform_blocks:
        if what is not None:
            what.bind_to_uniform_block(point)  # a whole buffer, sized by its owner
    limit = None
    for name, binding, what in blocks:
        if what is None:
            continue
        if not isinstance(what, Storage):
            what.bind_to_storage_buffer(binding)  # a whole buffer: the block reads what it declares
            continue
        size = what.buffer.size - what.offset if what.size is None else what.size
        limit = max_block_bytes() if limit is None else limit
        if size > limit:
            raise ValueError(f"{found.label}: storage block {name}: a {size}-byte range exceeds the "
                             f"driver's {limit}-byte block limit")
        what.buffer.bind_to_storage_buffer(binding, offset=what.offset, size=max(size, 4))
    if found.images:
        tables = (images or _NOTHING, *(part.images for part in parts))
        for name, unit in found.images.items():
            image = _first(tables, name)
            if image is not None and image is not _ABSENT:
                image.texture.bind_to_image(unit, read=image.read, write=image.write, level=image.level)
    if found.samplers:
        tables = (textures or _NOTHING, *(part.textures for part in parts))
        for name, unit in found.samplers.items():
            texture = _first(tables, name)
            if texture is not None and texture is not _ABSENT:
                texture.use(location=unit)
    _set_layout_uniforms(found, (uniforms or _NOTHING, *(part.uniforms for part in parts)))


_NOTHING: Mapping[str, object] = {}


def _first(tables, name: str):
    """``name``'s value in the first of ``tables`` that has it (_ABSENT when none has)."""
    for table in tables:
        what = table.get(name, _ABSENT)
        if what is not _ABSENT:
            return what
    return _ABSENT
