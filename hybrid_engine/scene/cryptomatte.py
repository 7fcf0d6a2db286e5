# SPDX-License-Identifier: GPL-3.0-or-later
"""Cryptomatte's names, ids and manifest, as the Cryptomatte specification (Psyop 2015,
``specification/cryptomatte_specification.pdf``) and Blender define them.

A Cryptomatte pass stores per pixel (id, coverage) pairs, the id being a float made from the
MurmurHash3 (x86, 32 bit, seed 0) of the object's, material's or asset's name. Compositors
(Blender's Cryptomatte node, Nuke's) turn a picked name back into that float, so the id
must be computed exactly as Blender computes it (``BKE_cryptomatte_hash``,
``BKE_cryptomatte_hash_to_float``): any other hash, or a float that differs in one bit,
selects nothing. The manifest (name -> hash in hex) travels in the image's metadata under
keys derived from the layer's name (``BKE_cryptomatte_meta_data_key``), so a file opened
elsewhere still resolves names.
"""
from __future__ import annotations

import json
import struct
from dataclasses import dataclass

# The kinds Blender's View Layer offers, as the passes' names spell them (CryptoObject00...).
KINDS = {"object": "CryptoObject", "material": "CryptoMaterial", "asset": "CryptoAsset"}


def murmur3_32(data: bytes, seed: int = 0) -> int:
    """MurmurHash3_x86_32 of ``data`` (Austin Appleby's reference, which Blender ships)."""
    c1, c2, mask = 0xCC9E2D51, 0x1B873593, 0xFFFFFFFF
    h = seed & mask
    length = len(data)
    body = length - length % 4
    for i in range(0, body, 4):
        k = struct.unpack_from("<I", data, i)[0]
        k = (k * c1) & mask
        k = ((k << 15) | (k >> 17)) & mask
        h ^= (k * c2) & mask
        h = ((h << 13) | (h >> 19)) & mask
        h = (h * 5 + 0xE6546B64) & mask
    k = 0
    tail = data[body:]
    for i in reversed(range(len(tail))):
        k = (k << 8) | tail[i]
    if tail:
        k = (k * c1) & mask
        k = ((k << 15) | (k >> 17)) & mask
        h ^= (k * c2) & mask
    h ^= length
    h ^= h >> 16
    h = (h * 0x85EBCA6B) & mask
    h ^= h >> 13
    h = (h * 0xC2B2AE35) & mask
    h ^= h >> 16
    return h


def name_hash(name: str) -> int:
    """The 32-bit hash of a name (its UTF-8 bytes), as Blender's manifest lists it."""
    return murmur3_32(name.encode("utf-8"))


def hash_to_float(value: int) -> float:
    """The float a pixel stores for a hash: its bits, with the exponent kept off 0 and 255 so
    that the id is never a denormal, an infinity or a NaN (the specification's rule)."""
    exponent = min(max((value >> 23) & 0xFF, 1), 254)
    bits = (value & 0x80000000) | (exponent << 23) | (value & 0x7FFFFF)
    return struct.unpack("<f", struct.pack("<I", bits))[0]


def name_id(name: str) -> float:
    """The id of ``name`` in a Cryptomatte pass."""
    return hash_to_float(name_hash(name))


def pass_names(kind: str, levels: int) -> list[str]:
    """The passes of a kind at ``levels`` ranks: two (id, coverage) pairs per RGBA pass."""
    return [f"{KINDS[kind]}{i:02d}" for i in range((levels + 1) // 2)]


@dataclass(frozen=True)
class CryptomatteRequest:
    """What a frame's Cryptomatte passes hold: the ``kinds`` asked for (of KINDS, in that
    order), ``levels`` (id, coverage) pairs per pixel, and per object of the scene's
    geometry (its order) the name of its asset (its topmost parent; () takes each object's
    own name)."""

    kinds: tuple[str, ...]
    levels: int = 6
    assets: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        unknown = set(self.kinds) - set(KINDS)
        if unknown or not self.kinds:
            raise ValueError(f"Cryptomatte kinds must be some of {', '.join(KINDS)}, got {self.kinds}")
        if not 1 <= self.levels <= 16:
            raise ValueError(f"Cryptomatte levels must lie in 1..16, got {self.levels}")

    @property
    def slots(self) -> int:
        """Ranks kept per pixel and kind: the levels rounded up to whole RGBA passes."""
        return 2 * ((self.levels + 1) // 2)


def object_name(name: str) -> str:
    """The object's own name in a geometry name (an instance is named ``parent/object``)."""
    return name.rsplit("/", 1)[-1]


def metadata_key(layer: str) -> str:
    """The metadata prefix of a Cryptomatte layer (``ViewLayer.CryptoObject``): its name's
    hash, first seven hex digits (Blender's ``BKE_cryptomatte_meta_data_key``)."""
    return f"cryptomatte/{name_hash(layer):08x}"[:len("cryptomatte/") + 7]


def manifest(names) -> str:
    """The manifest JSON of ``names``, as Blender writes it: {"name":"hash in hex", ...}."""
    entries = dict.fromkeys(names)
    return json.dumps({name: f"{name_hash(name):08x}" for name in entries}, separators=(",", ":"),
                      ensure_ascii=False)


def metadata(view_layer: str, kind: str, names) -> dict[str, str]:
    """The four metadata fields Blender writes for one kind's layer of ``view_layer``."""
    layer = f"{view_layer}.{KINDS[kind]}"
    key = metadata_key(layer)
    return {f"{key}/name": layer, f"{key}/hash": "MurmurHash3_32", f"{key}/conversion": "uint32_to_float32",
            f"{key}/manifest": manifest(names)}
