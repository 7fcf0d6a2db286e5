# SPDX-License-Identifier: GPL-3.0-or-later
"""Alpha as Blender defines it: the coverage of a surface, read from the Principled BSDF's
Alpha input and from a Transparent BSDF mixed in by a Mix Shader (the two ways artists and
importers cut leaves, chains and fences out of cards), into the material row's ``alpha``,
``alpha_texture``, ``alpha_channel`` and ``alpha_clip`` (hybrid_engine/scene/data.py).

What is read, per socket (the Alpha input, or the Mix Shader's Factor):

* its own value, when unlinked;
* an Image Texture's Alpha output (the image's alpha channel), its Color output (read as
  red: the grey masks such links carry), or one channel of its Color through a Separate
  Color node;
* either of these through ``1 - (x < cutoff)`` (Math Subtract of Less Than: glTF's MASK
  mode as Blender's importer builds it), ``x > cutoff`` (Greater Than) or Round (cutoff
  0.5): a clip of the image's value at the cutoff.

Anything else is named to the artist once and the socket's own value is used. Blender 4.2's
*Render Method* (``surface_render_method``): DITHERED is what every pass here does; BLENDED
is rendered the same way, stochastic coverage whose accumulated samples converge to the
blend (as Cycles, which ignores the setting), and the artist is told once that it is not
EEVEE's sorted blending.
"""
from __future__ import annotations

from . import tell
from .images import image_pixels

# Separate Color outputs -> hybrid_engine.scene.data.ALPHA_CHANNELS.
_SEPARATED = {"Red": 0, "Green": 1, "Blue": 2, "R": 0, "G": 1, "B": 2}
_ALPHA, _RED = 3, 0


def _linked(socket):
    """(node, output socket) feeding ``socket`` through reroutes; (None, None) when unlinked
    or the link is muted."""
    while socket is not None and socket.is_linked:
        link = socket.links[0]
        if link.is_muted:
            return None, None
        if link.from_node.type != "REROUTE":
            return link.from_node, link.from_socket
        socket = link.from_node.inputs[0]
    return None, None


def _image_channel(node, output):
    """(image, channel) of an Image Texture output, or of one channel of one through a
    Separate Color node; None otherwise."""
    if node is None or node.mute:
        return None
    channel = None
    if node.type in ("SEPARATE_COLOR", "SEPRGB") and output.name in _SEPARATED:
        if getattr(node, "mode", "RGB") != "RGB":
            return None
        channel = _SEPARATED[output.name]
        node, output = _linked(node.inputs[0])
        if node is None or node.mute or output.name != "Color":
            return None
    if node.type != "TEX_IMAGE" or node.image is None:
        return None
    if channel is None:
        channel = _ALPHA if output.name == "Alpha" else _RED
    return node.image, channel


def _constant(socket) -> float | None:
    """An unlinked value socket's value, else None."""
    if socket is None or socket.is_linked or not hasattr(socket, "default_value"):
        return None
    return float(socket.default_value)


def _clipped(node, output):
    """(image, channel, cutoff) of a Math node that thresholds an image's value, else None."""
    if node is None or node.type != "MATH" or node.mute:
        return None
    a, b = node.inputs[0], node.inputs[1]
    if node.operation == "SUBTRACT" and _constant(a) == 1.0:
        inner, inner_out = _linked(b)
        if inner is not None and inner.type == "MATH" and inner.operation == "LESS_THAN" and not inner.mute:
            source = _image_channel(*_linked(inner.inputs[0]))
            cutoff = _constant(inner.inputs[1])
            if source is not None and cutoff is not None:
                return (*source, cutoff)
        return None
    if node.operation == "GREATER_THAN":
        source, cutoff = _image_channel(*_linked(a)), _constant(b)
    elif node.operation == "ROUND":
        source, cutoff = _image_channel(*_linked(a)), 0.5
    else:
        return None
    return (*source, cutoff) if source is not None and cutoff is not None else None


def read_coverage(socket, owner: str, what: str, quiet: bool = False) -> dict:
    """The coverage a value socket gives, as material-row keys: ``alpha`` (its value, or 1
    for an image), and for an image ``alpha_texture`` (pixels), ``alpha_channel`` and
    ``alpha_clip`` (0: none). ``quiet``: what it cannot read is not told (a node program
    computes the coverage instead)."""
    own = _constant(socket) if socket is not None and not socket.is_linked else None
    if socket is None:
        return {"alpha": 1.0}
    if own is not None:
        return {"alpha": own}
    node, output = _linked(socket)
    if node is None:
        return {"alpha": float(socket.default_value)}
    found = _image_channel(node, output)
    found = (*found, 0.0) if found is not None else _clipped(node, output)
    if found is None:
        if not quiet:
            tell("%s: %s is linked to %r, which is not an image's alpha or channel (or a clip of "
                 "one); its own value is used", owner, what, node.name)
        return {"alpha": float(socket.default_value)}
    image, channel, cutoff = found
    pixels = image_pixels(image)
    if pixels is None:
        return {"alpha": float(socket.default_value)}
    return {"alpha": 1.0, "alpha_texture": pixels, "alpha_channel": channel, "alpha_clip": float(cutoff)}


def split_transparent(node, owner: str, quiet: bool = False):
    """(the shader node to read as the surface, coverage row keys) of a material's surface
    node. A Mix Shader of a Transparent BSDF and another shader is the other shader with a
    coverage of the mix's factor (Blender mixes (1 - f) A + f B: f when the Transparent BSDF
    is A; 1 - f when it is B, for an unlinked factor); a lone Transparent BSDF covers
    nothing. Other nodes come back unchanged, with no coverage keys."""
    if node is None:
        return node, {}
    if node.type == "BSDF_TRANSPARENT":
        _tell_tinted(node, owner)
        return None, {"alpha": 0.0}
    if node.type != "MIX_SHADER" or node.mute:
        return node, {}
    factor = node.inputs[0]
    a, _ = _linked(node.inputs[1])
    b, _ = _linked(node.inputs[2])
    if a is not None and a.type == "BSDF_TRANSPARENT" and (b is None or b.type != "BSDF_TRANSPARENT"):
        _tell_tinted(a, owner)
        return b, read_coverage(factor, owner, "the Mix Shader's Factor", quiet)
    if b is not None and b.type == "BSDF_TRANSPARENT" and a is not None:
        _tell_tinted(b, owner)
        value = _constant(factor)
        if value is None:
            if not quiet:
                tell("%s: the Transparent BSDF is the Mix Shader's second shader and its Factor is "
                     "linked; put the Transparent BSDF first for a mask to cut out, it is left opaque", owner)
            return a, {}
        return a, {"alpha": 1.0 - min(max(value, 0.0), 1.0)}
    return node, {}


def _tell_tinted(node, owner: str) -> None:
    color = tuple(node.inputs[0].default_value)[:3] if node.inputs else (1.0, 1.0, 1.0)
    if node.inputs and (node.inputs[0].is_linked or min(color) < 1.0):
        tell("%s: the Transparent BSDF's colour is taken as white (coverage only, no tint)", owner)


def render_method_note(material) -> None:
    """Tell the artist once that Blended materials render as dithered coverage."""
    if getattr(material, "surface_render_method", "DITHERED") == "BLENDED":
        tell("%s: Render Method Blended is rendered dithered: stochastic coverage that the "
             "samples average into the blend (as Cycles renders it), not EEVEE's sorted blending",
             material.name)


def surface_coverage(material, node, images: bool, quiet: bool = False) -> dict:
    """The coverage row keys of ``material`` whose surface node is ``node`` (the Principled
    BSDF's Alpha, a Transparent mix); without ``images`` only the factor (the material
    panel's row)."""
    render_method_note(material)
    surface, mixed = split_transparent(node, material.name, quiet)
    principled = {}
    if surface is not None and surface.type == "BSDF_PRINCIPLED":
        principled = read_coverage(surface.inputs.get("Alpha"), material.name, "Alpha", quiet)
    out = combine(principled, mixed, material.name)
    if not images:
        out = {"alpha": float(out.get("alpha", 1.0))}
    return out


def combine(principled: dict, mixed: dict, owner: str) -> dict:
    """One coverage from the Principled BSDF's Alpha and a Transparent mix: the factors
    multiply; of two images the mix's is kept (named to the artist)."""
    if not mixed:
        return principled
    if not principled:
        return mixed
    out = dict(mixed)
    out["alpha"] = float(principled.get("alpha", 1.0)) * float(mixed.get("alpha", 1.0))
    if "alpha_texture" in principled:
        if "alpha_texture" in mixed:
            tell("%s: both the Alpha input and the Transparent mix read an image; the mix's is used", owner)
        else:
            for key in ("alpha_texture", "alpha_channel", "alpha_clip"):
                out[key] = principled[key]
    return out
