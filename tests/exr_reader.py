# SPDX-License-Identifier: GPL-3.0-or-later
"""Read the channels of an uncompressed scan-line OpenEXR file (tests only).

Blender's Python API gives the pixels of an image's first pass only, but the data passes a
render engine writes (Depth, Normal) reach the user through multilayer EXR files
(``image_settings.file_format = 'OPEN_EXR_MULTILAYER'``). Saving with ``exr_codec = 'NONE'``
keeps the file simple enough to read here without a library: a header of typed attributes,
a table of chunk offsets, then one chunk per scan line holding each channel's row in
alphabetical channel order (OpenEXR file layout, "Scan Line Based Image Files").
"""
from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

_MAGIC = 20000630
_TILED, _DEEP, _MULTI_PART = 0x200, 0x800, 0x1000  # version-field flags (long names, 0x400, are fine)
_PIXEL_TYPES = {0: np.dtype("<u4"), 1: np.dtype("<f2"), 2: np.dtype("<f4")}


def _cstring(data: bytes, pos: int) -> tuple[str, int]:
    end = data.index(b"\0", pos)
    return data[pos:end].decode(), end + 1


def _read_header(data: bytes, pos: int) -> tuple[dict[str, tuple[str, bytes]], int]:
    """One header's attributes (name -> (type, raw value)) and the position after it."""
    header = {}
    while data[pos] != 0:
        name, pos = _cstring(data, pos)
        kind, pos = _cstring(data, pos)
        (size,) = struct.unpack_from("<i", data, pos)
        pos += 4
        header[name] = (kind, data[pos:pos + size])
        pos += size
    return header, pos + 1


def _channel_list(raw: bytes) -> list[tuple[str, np.dtype]]:
    channels, pos = [], 0
    while raw[pos] != 0:
        name, pos = _cstring(raw, pos)
        (pixel_type,) = struct.unpack_from("<i", raw, pos)
        pos += 16  # pixel type, pLinear + 3 reserved bytes, x and y sampling
        channels.append((name, _PIXEL_TYPES[pixel_type]))
    return channels


def read_exr_channels(path: str | Path) -> dict[str, np.ndarray]:
    """Every channel of the file as an (H, W) float32 array, row 0 at the BOTTOM (Blender's
    order; the file stores the top row first). In a multi-part file (Blender's multilayer
    EXR) a channel is keyed by its part's name and its own, joined by a dot unless the
    channel name already carries the part's. Raises ValueError for files this reader does
    not handle (compressed, tiled, deep)."""
    data = Path(path).read_bytes()
    magic, version = struct.unpack_from("<ii", data, 0)
    if magic != _MAGIC:
        raise ValueError(f"{path} is not an OpenEXR file")
    if version & (_TILED | _DEEP):
        raise ValueError(f"{path}: only scan-line files are read (version flags {version:#x})")
    multi_part = bool(version & _MULTI_PART)
    pos, headers = 8, []
    while True:
        header, pos = _read_header(data, pos)
        headers.append(header)
        if not multi_part or data[pos] == 0:
            break
    pos += int(multi_part)  # the empty header that ends a multi-part file's list
    parts = []
    for header in headers:
        if header["compression"][1][0] != 0:
            raise ValueError(f"{path} is compressed: save it with exr_codec 'NONE'")
        xmin, ymin, xmax, ymax = struct.unpack_from("<iiii", header["dataWindow"][1], 0)
        height = ymax - ymin + 1
        parts.append((header, _channel_list(header["channels"][1]), xmin, ymin, xmax - xmin + 1, height))
        pos += 8 * height  # this part's offset table (one chunk per scan line, uncompressed)
    out = {}
    for index, (header, channels, _x, ymin, width, height) in enumerate(parts):
        prefix = header["name"][1].rstrip(b"\0").decode() if "name" in header else ""
        keys = [name if not prefix or name.startswith(prefix + ".") else f"{prefix}.{name}" for name, _ in channels]
        images = [np.empty((height, width), np.float32) for _ in channels]
        for _ in range(height):
            if multi_part:
                part, y, _size = struct.unpack_from("<iii", data, pos)
                pos += 12
                if part != index:
                    raise ValueError(f"{path}: chunks of part {part} interleaved with part {index}'s")
            else:
                y, _size = struct.unpack_from("<ii", data, pos)
                pos += 8
            row = y - ymin
            for image, (_name, dtype) in zip(images, channels):
                image[row] = np.frombuffer(data, dtype, width, pos)
                pos += width * dtype.itemsize
        out.update({key: image[::-1].copy() for key, image in zip(keys, images)})
    return out
