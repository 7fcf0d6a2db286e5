# SPDX-License-Identifier: GPL-3.0-or-later
"""Plain-array scene description: what the renderer core consumes.

The Blender adapter turns a depsgraph into these dataclasses; tests and benchmarks build
them directly: the geometry (geometry.py), the material table, the lamps and the World.

Units follow Blender: metres, light power in watts (point/spot/area) and irradiance in W/m²
(sun), colours linear Rec.709.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .arrays import SceneDataError, as_array
from .geometry import Geometry
from .closure_alpha import has_closure_alpha
from .shader_graph import ShaderGraph
from .sky_sun import sun_rows

# Light kinds (std430 int in the light buffer)
LIGHT_POINT, LIGHT_SUN, LIGHT_SPOT, LIGHT_AREA = 0, 1, 2, 3
LIGHT_KINDS = {"POINT": LIGHT_POINT, "SUN": LIGHT_SUN, "SPOT": LIGHT_SPOT, "AREA": LIGHT_AREA}
# Light and shadow linking (light_linking.py): sets 0..63, as Blender's light sets; a lamp's
# masks hold one bit per set, all of them when the lamp is not linked.
MAX_LINK_SETS = 64
ALL_LINK_SETS = np.uint64(0xFFFF_FFFF_FFFF_FFFF)
# The keys MaterialTable.from_rows reads, and those it leaves to the node graphs' table
# (the adapter's graph_rows.table_with_graphs).
_MATERIAL_ROW_KEYS = frozenset((
    "base_color", "emission", "reflectivity", "transmission", "ior", "thickness", "roughness", "specular",
    "name", "base_color_texture", "emission_texture", "normal_texture", "normal_strength", "roughness_texture",
    "roughness_channel", "metallic_texture", "metallic_channel", "alpha", "alpha_texture", "alpha_channel",
    "alpha_clip", "light_set", "shadow_set", "emitter_light_mask", "emitter_shadow_mask",
    "node_graph", "node_graph_textures"))
# The keys Lights.from_rows reads.
_LIGHT_ROW_KEYS = frozenset((
    "kind", "position", "direction", "color", "radius", "spot_size", "spot_blend", "cast_shadow", "name",
    "area_axis", "area_size_y", "area_elliptic", "light_mask", "shadow_mask"))


def check_row_keys(rows, known: frozenset, what: str) -> None:
    """A row key the table does not read (``energy`` rather than ``color``, ``metallic``
    rather than ``reflectivity``) would fall back to its default without a word: an error
    naming the row and the key instead."""
    for row in rows:
        unknown = sorted(set(row) - known)
        if unknown:
            raise ValueError(f"{what} row {row.get('name', '?')!r}: unknown keys {', '.join(unknown)}")


@dataclass
class MaterialTable:
    """Per-material parameters, derived from Blender's Principled BSDF (see README.md,
    "Materials and the per-material thickness").

    ``reflectivity`` is the weight of the metal lobe (Metallic), tinted by ``base_color``;
    ``transmission`` the weight of the glass lobe of index ``ior``; what remains is diffuse,
    under a dielectric specular coat whose reflectance at normal incidence is ``specular``
    (0: none; Blender's Specular IOR Level folded in by materials.py). ``roughness`` (GGX)
    applies to every specular lobe: 0 is a perfect mirror or clear glass
    (gpu_shaders/include/shading.glsl). ``thickness`` is the paper's per-material
    thickness (§3.4): 0 thin, 1 solid to the cube map's far plane.

    Image textures: ``textures`` holds the scene's images and ``base_color_texture[i]`` /
    ``emission_texture[i]`` index it (-1: none). A texture *multiplies* the material's
    factor: albedo = base_color * texture(uv).rgb, emission = emission * texture(uv).rgb.
    Blender ignores a socket's own value once an Image Texture is linked to it, so the
    extractor stores a factor of 1 for a direct link (and the constant of a Multiply mix
    for a ``colour × image`` link); scenes built by hand can use the factor as a tint.
    ``roughness_texture[i]`` / ``metallic_texture[i]`` give the roughness / metallic (the
    factors are then unused, as Blender ignores a linked socket's value) from the channel
    ``roughness_channel`` / ``metallic_channel`` (``TEXTURE_CHANNELS``: a glTF's packed
    image reads green and blue) of a Non-Color image.
    ``normal_texture[i]`` is a tangent-space normal map (Blender's Normal Map node: colour
    ``n * 0.5 + 0.5`` in the frame of the UVs' directions, OpenGL's +Y), blended with the
    shading normal by ``normal_strength``; its image is stored as is (Non-Color).
    Texture coordinates are the triangles' ``Geometry.uvs`` (zero when absent), wrapped
    by repetition.

    Alpha (Blender's coverage: the Principled BSDF's Alpha, a Transparent BSDF mixed in):
    ``alpha[i]`` is the fraction of the surface that is there, times the value of
    ``alpha_texture[i]``'s channel ``alpha_channel[i]`` (``ALPHA_CHANNELS``: an image's
    alpha, or one colour channel of a mask) where it has one, that value first clipped to 0
    or 1 at ``alpha_clip[i]`` where that is above 0 (glTF's MASK mode). Every pass that sees a
    surface keeps a fragment or a hit with that probability, per pixel and sample
    (gpu_shaders/include/alpha.glsl), so accumulated samples converge to the fractional
    coverage Cycles renders; a table without alpha compiles none of it (``has_alpha``).

    Each texture is (H, W, 4) (or (H, W, 3), given alpha 1) float32 *linear* RGBA, row 0
    at the bottom (v = 0), the order of Blender's ``Image.pixels`` and of OpenGL; 8-bit
    sRGB images must be decoded first (``hybrid_engine.passes.scene_upload.textures.srgb_to_linear``). Arrays
    already in that form are kept as they are, not copied, and are treated as immutable:
    the GPU copy is refreshed when the list holds different arrays, not when an array is
    changed in place. Non-finite or negative texels are not rejected here (checking every
    texel every frame would cost more than the frame); the upload replaces them (documented
    fallback in ``hybrid_engine.passes.scene_upload.textures.pack_layers``).
    """

    base_color: np.ndarray  # (M, 3) float32, linear
    emission: np.ndarray  # (M, 3) float32, radiance added (colour * strength)
    reflectivity: np.ndarray  # (M,) float32 in [0, 1]
    transmission: np.ndarray  # (M,) float32 in [0, 1]
    ior: np.ndarray  # (M,) float32 >= 1
    thickness: np.ndarray  # (M,) float32 in [0, 1]
    names: list[str] = field(default_factory=list)
    roughness: np.ndarray | None = None  # (M,) float32 in [0, 1]; None: all 0
    specular: np.ndarray | None = None  # (M,) float32 in [0, 1], coat reflectance; None: all 0
    base_color_texture: np.ndarray | None = None  # (M,) int32 index into textures, -1 none
    emission_texture: np.ndarray | None = None  # (M,) int32 index into textures, -1 none
    textures: list[np.ndarray] = field(default_factory=list)  # (H, W, 4) float32 linear
    normal_texture: np.ndarray | None = None  # (M,) int32 tangent-space normal map, -1 none
    normal_strength: np.ndarray | None = None  # (M,) float32 Normal Map strength; None: all 1
    roughness_texture: np.ndarray | None = None  # (M,) int32 image giving the roughness, -1 none
    metallic_texture: np.ndarray | None = None  # (M,) int32 image giving the metallic, -1 none
    roughness_channel: np.ndarray | None = None  # (M,) int32 TEXTURE_CHANNELS index; None: all 3
    metallic_channel: np.ndarray | None = None  # (M,) int32 TEXTURE_CHANNELS index; None: all 3
    alpha: np.ndarray | None = None  # (M,) float32 coverage in [0, 1]; None: all 1 (opaque)
    alpha_texture: np.ndarray | None = None  # (M,) int32 image giving the coverage, -1 none
    alpha_channel: np.ndarray | None = None  # (M,) int32 ALPHA_CHANNELS index; None: all 3 (alpha)
    alpha_clip: np.ndarray | None = None  # (M,) float32 cutoff of the alpha image's value, 0: none
    # Per material, its shader node graph (shader_graph.py) where the fixed rows above cannot
    # hold what the artist built, else None; None for the whole table: no graphs at all.
    node_graphs: list[ShaderGraph | None] | None = None
    # Light and shadow linking (scene/light_linking.py): the receiver set and the blocker set
    # of the objects that wear this row (Cycles' light sets); None: all 0, the default set
    # every lamp lights and every shadow holds.
    light_set: np.ndarray | None = None  # (M,) int32 in 0..MAX_LINK_SETS - 1
    shadow_set: np.ndarray | None = None  # (M,) int32 in 0..MAX_LINK_SETS - 1
    # Emissive objects are emitters of the linking too (Cycles' mesh lights): bit s of
    # ``emitter_light_mask[i]`` says the emission of the objects that wear row i lights
    # receiver set s, of ``emitter_shadow_mask[i]`` that blocker set s shadows it; None: every
    # set (passes/emitters/emitter_links.py).
    emitter_light_mask: np.ndarray | None = None  # (M,) uint64
    emitter_shadow_mask: np.ndarray | None = None  # (M,) uint64

    def __post_init__(self) -> None:
        self.base_color = as_array(self.base_color, np.float32, (3,), "base_color")
        m = len(self.base_color)
        for name in ("emitter_light_mask", "emitter_shadow_mask"):
            value = getattr(self, name)
            masks = np.full(m, ALL_LINK_SETS, np.uint64) if value is None else np.asarray(value, np.uint64).reshape(-1)
            if len(masks) != m:
                raise SceneDataError(f"material {name} has {len(masks)} rows, expected {m}")
            setattr(self, name, masks)
        for name in ("light_set", "shadow_set"):
            value = getattr(self, name)
            sets = np.zeros(m, np.int32) if value is None else as_array(value, np.int32, (), name)
            if len(sets) != m or ((sets < 0) | (sets >= MAX_LINK_SETS)).any():
                raise SceneDataError(f"material {name} must hold {m} values in 0..{MAX_LINK_SETS - 1}")
            setattr(self, name, sets)
        self.emission = as_array(self.emission, np.float32, (3,), "emission")
        for name in ("roughness", "specular"):
            if getattr(self, name) is None:
                setattr(self, name, np.zeros(m, np.float32))
        for name in ("reflectivity", "transmission", "ior", "thickness", "roughness", "specular"):
            setattr(self, name, as_array(getattr(self, name), np.float32, (), name))
        for name in ("emission", "reflectivity", "transmission", "ior", "thickness", "roughness", "specular"):
            if len(getattr(self, name)) != m:
                raise SceneDataError(f"material {name} has {len(getattr(self, name))} rows, expected {m}")
        if not self.names:
            self.names = [f"material_{i}" for i in range(m)]
        self.textures = [_texture(t, i) for i, t in enumerate(self.textures)]
        if self.normal_strength is None:
            self.normal_strength = np.ones(m, np.float32)
        self.normal_strength = as_array(self.normal_strength, np.float32, (), "normal_strength")
        if len(self.normal_strength) != m:
            raise SceneDataError(f"material normal_strength has {len(self.normal_strength)} rows, expected {m}")
        self.alpha = np.ones(m, np.float32) if self.alpha is None else as_array(self.alpha, np.float32, (), "alpha")
        self.alpha_clip = (np.zeros(m, np.float32) if self.alpha_clip is None
                           else as_array(self.alpha_clip, np.float32, (), "alpha_clip"))
        for name in ("alpha", "alpha_clip"):
            if len(getattr(self, name)) != m:
                raise SceneDataError(f"material {name} has {len(getattr(self, name))} rows, expected {m}")
        for name, names, fallback in (("roughness_channel", TEXTURE_CHANNELS, LUMINANCE_CHANNEL),
                                      ("metallic_channel", TEXTURE_CHANNELS, LUMINANCE_CHANNEL),
                                      ("alpha_channel", ALPHA_CHANNELS, ALPHA_CHANNEL)):
            value = getattr(self, name)
            channel = np.full(m, fallback, np.int32) if value is None else as_array(value, np.int32, (), name)
            if len(channel) != m or ((channel < 0) | (channel >= len(names))).any():
                raise SceneDataError(f"material {name} must hold {m} values in 0..{len(names) - 1} "
                                     f"({', '.join(names)})")
            setattr(self, name, channel)
        for name in TEXTURE_SLOTS:
            value = getattr(self, name)
            index = np.full(m, -1, np.int32) if value is None else as_array(value, np.int32, (), name)
            if len(index) != m:
                raise SceneDataError(f"material {name} has {len(index)} rows, expected {m}")
            bad = np.flatnonzero((index < -1) | (index >= len(self.textures)))
            if len(bad):
                k = int(bad[0])
                raise SceneDataError(
                    f"material {k} ({self.names[k]!r}) has {name} {int(index[k])}, but there "
                    f"are {len(self.textures)} textures (valid: -1 for none, 0..{len(self.textures) - 1})"
                )
            setattr(self, name, index)
        if self.node_graphs is not None:
            self.node_graphs = list(self.node_graphs)
            if len(self.node_graphs) != m:
                raise SceneDataError(f"material node_graphs has {len(self.node_graphs)} entries, expected {m}")
            for k, graph in enumerate(self.node_graphs):
                if graph is not None and not isinstance(graph, ShaderGraph):
                    raise SceneDataError(f"material {k} ({self.names[k]!r}) node graph is a "
                                         f"{type(graph).__name__}, not a ShaderGraph")

    @property
    def has_textures(self) -> bool:
        """True when some material samples a texture."""
        return bool(any((getattr(self, name) >= 0).any() for name in TEXTURE_SLOTS))

    @property
    def has_alpha(self) -> bool:
        """True when some surface is not wholly there (alpha below 1, an alpha image, or a
        node graph's closure alpha):
        only then do the passes compile their alpha tests (``ALPHA_TEST``)."""
        if (np.nan_to_num(self.alpha, nan=1.0) < 1.0).any() or (self.alpha_texture >= 0).any():
            return True
        # -- closure alpha: a graph's Transparent BSDF or Principled Alpha (closure_alpha.py)
        return any(has_closure_alpha(graph) for graph in self.node_graphs or ())

    def __len__(self) -> int:
        return int(len(self.base_color))

    @classmethod
    def default(cls) -> "MaterialTable":
        """One grey diffuse material (Blender's default surface, base colour 0.8)."""
        return cls.from_rows([dict(name="default")])

    @classmethod
    def from_rows(cls, rows: list[dict], textures: list[np.ndarray] | None = None) -> "MaterialTable":
        """Build from dicts with keys base_color, emission, reflectivity, transmission, ior,
        thickness, roughness, specular, name, base_color_texture, emission_texture,
        normal_texture, normal_strength, roughness_texture, roughness_channel,
        metallic_texture, metallic_channel, alpha, alpha_texture, alpha_channel, alpha_clip,
        light_set, shadow_set, emitter_light_mask, emitter_shadow_mask (all optional); any
        other key is a ValueError.

        A texture key holds an index into ``textures``, None (no texture) or the image
        array itself; arrays are appended to the texture list once per array object, so
        materials sharing an image share one texture.
        """
        check_row_keys(rows, _MATERIAL_ROW_KEYS, "material")
        get = lambda key, default: [r.get(key, default) for r in rows]  # noqa: E731
        texture_list = list(textures or [])
        slot_of = {id(t): i for i, t in enumerate(texture_list)}

        def texture_index(value) -> int:
            if value is None:
                return -1
            if isinstance(value, np.ndarray) and value.ndim >= 2:
                if id(value) not in slot_of:
                    slot_of[id(value)] = len(texture_list)
                    texture_list.append(value)
                return slot_of[id(value)]
            return int(value)

        return cls(
            base_color=np.array(get("base_color", (0.8, 0.8, 0.8)), np.float32).reshape(-1, 3),
            emission=np.array(get("emission", (0.0, 0.0, 0.0)), np.float32).reshape(-1, 3),
            reflectivity=np.array(get("reflectivity", 0.0), np.float32),
            transmission=np.array(get("transmission", 0.0), np.float32),
            ior=np.array(get("ior", 1.45), np.float32),
            thickness=np.array(get("thickness", 0.5), np.float32),
            roughness=np.array(get("roughness", 0.0), np.float32),
            specular=np.array(get("specular", 0.0), np.float32),
            names=[str(n) for n in get("name", "material")],
            base_color_texture=np.array([texture_index(v) for v in get("base_color_texture", None)], np.int32),
            emission_texture=np.array([texture_index(v) for v in get("emission_texture", None)], np.int32),
            normal_texture=np.array([texture_index(v) for v in get("normal_texture", None)], np.int32),
            normal_strength=np.array(get("normal_strength", 1.0), np.float32),
            roughness_texture=np.array([texture_index(v) for v in get("roughness_texture", None)], np.int32),
            metallic_texture=np.array([texture_index(v) for v in get("metallic_texture", None)], np.int32),
            roughness_channel=np.array(get("roughness_channel", LUMINANCE_CHANNEL), np.int32),
            metallic_channel=np.array(get("metallic_channel", LUMINANCE_CHANNEL), np.int32),
            alpha=np.array(get("alpha", 1.0), np.float32),
            alpha_texture=np.array([texture_index(v) for v in get("alpha_texture", None)], np.int32),
            alpha_channel=np.array(get("alpha_channel", ALPHA_CHANNEL), np.int32),
            alpha_clip=np.array(get("alpha_clip", 0.0), np.float32),
            textures=texture_list,
            light_set=np.array(get("light_set", 0), np.int32),
            shadow_set=np.array(get("shadow_set", 0), np.int32),
            emitter_light_mask=np.array([int(v) for v in get("emitter_light_mask", int(ALL_LINK_SETS))], np.uint64),
            emitter_shadow_mask=np.array([int(v) for v in get("emitter_shadow_mask", int(ALL_LINK_SETS))], np.uint64),
        )

    def packed(self) -> np.ndarray:
        """std430 rows of ``struct Material`` (gpu_shaders/include/scene_layout.glsl)."""
        out = np.zeros(len(self), MATERIAL_DTYPE)
        out["base_color"][:, :3] = self.base_color
        out["base_color"][:, 3] = self.reflectivity
        out["emission"][:, :3] = self.emission
        out["emission"][:, 3] = self.transmission
        out["params"][:, 0] = self.ior
        out["params"][:, 1] = self.thickness
        out["params"][:, 2] = np.clip(self.roughness, 0.0, 1.0)
        out["params"][:, 3] = np.clip(self.specular, 0.0, 1.0)
        out["textures"][:, 0] = self.base_color_texture
        out["textures"][:, 1] = self.emission_texture
        out["textures"][:, 2] = self.normal_texture
        # The Normal Map strength in thousandths (an int slot: the float ones are all used).
        strength = np.nan_to_num(np.clip(self.normal_strength, 0.0, 100.0))
        out["textures"][:, 3] = np.where(self.normal_texture >= 0, np.round(strength * 1000.0), -1)
        # Roughness and metallic images: layer * 4 + the channel read (TEXTURE_CHANNELS); w is
        # the node program's first word, which the upload fills in (scene_upload/node_programs.py).
        out["textures2"][:] = -1
        for column, (layer, channel) in enumerate(((self.roughness_texture, self.roughness_channel),
                                                   (self.metallic_texture, self.metallic_channel))):
            out["textures2"][:, column] = np.where(layer >= 0, layer * 4 + channel, -1)
        # Coverage: the factor, and its image as layer * 4 + ALPHA_CHANNELS index.
        out["params2"][:, 0] = np.clip(np.nan_to_num(self.alpha, nan=1.0), 0.0, 1.0)
        out["params2"][:, 1] = np.where(self.alpha_texture >= 0, np.nan_to_num(self.alpha_clip), 0.0)
        out["textures2"][:, 2] = np.where(self.alpha_texture >= 0, self.alpha_texture * 4 + self.alpha_channel, -1)
        # The linking sets (exact in a float: at most MAX_LINK_SETS); 0 unless linked.
        out["params2"][:, 2] = self.light_set
        out["params2"][:, 3] = self.shadow_set
        return out


# struct Material { vec4 base_color_refl; vec4 emission_trans; vec4 params; ivec4 textures; ivec4 textures2;
#                  vec4 params2; }
MATERIAL_DTYPE = np.dtype(
    [("base_color", np.float32, 4), ("emission", np.float32, 4), ("params", np.float32, 4),
     ("textures", np.int32, 4), ("textures2", np.int32, 4), ("params2", np.float32, 4)]
)
assert MATERIAL_DTYPE.itemsize == 96  # total: 96 bytes
# The material's image slots (MaterialTable attributes holding texture indices).
TEXTURE_SLOTS = ("base_color_texture", "emission_texture", "normal_texture", "roughness_texture",
                 "metallic_texture", "alpha_texture")
# What a roughness or metallic image gives: one channel, or the luminance (Blender's colour
# to value conversion, Rec.709 weights) of its colour.
TEXTURE_CHANNELS = ("red", "green", "blue", "luminance")
LUMINANCE_CHANNEL = 3
# What an alpha image gives (textures2.z's low two bits): its alpha channel (an Image
# Texture's Alpha output), or one colour channel of a mask (a Separate Color output, or a
# Color output, read as red: exact for the grey masks such links carry).
ALPHA_CHANNELS = ("red", "green", "blue", "alpha")
ALPHA_CHANNEL = 3


def _texture(array, index: int) -> np.ndarray:
    """One texture as (H, W, 4) float32, the same object when it already is one."""
    arr = np.asarray(array)
    if arr.dtype.kind != "f":
        raise SceneDataError(
            f"texture {index} has dtype {arr.dtype}; textures are float linear RGBA (decode 8-bit "
            "sRGB images with hybrid_engine.passes.scene_upload.textures.srgb_to_linear)"
        )
    if arr.ndim != 3 or arr.shape[2] not in (3, 4) or arr.shape[0] < 1 or arr.shape[1] < 1:
        raise SceneDataError(f"texture {index} must have shape (H, W, 4) or (H, W, 3), got {arr.shape}")
    if arr.shape[2] == 3:
        arr = np.concatenate([arr, np.ones(arr.shape[:2] + (1,), arr.dtype)], axis=2)
    return np.ascontiguousarray(arr, np.float32)


def area_basis(normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors completing each unit normal of ``normals`` (L, 3) to an orthonormal
    basis, continuous except where the normal's z crosses 0 (Duff et al. 2017, "Building an
    Orthonormal Basis, Revisited"). An area lamp's x axis is stored as its angle in this
    basis, and gpu_shaders/include/lighting.glsl builds the same basis from the same normal,
    so the lamp row needs one float for its orientation."""
    n = np.asarray(normals, np.float64).reshape(-1, 3)
    length = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.where(length > 0, n / np.where(length > 0, length, 1.0), [0.0, 0.0, -1.0])
    sign = np.where(n[:, 2] >= 0.0, 1.0, -1.0)
    a = -1.0 / (sign + n[:, 2])
    b = n[:, 0] * n[:, 1] * a
    t1 = np.stack([1.0 + sign * n[:, 0] ** 2 * a, sign * b, -sign * n[:, 0]], axis=1)
    t2 = np.stack([b, sign + n[:, 1] ** 2 * a, -n[:, 1]], axis=1)
    return t1.astype(np.float32), t2.astype(np.float32)


@dataclass
class Lights:
    """Punctual lights in Blender's units.

    ``power`` is watts for point/spot/area (Blender's "Power") and W/m² for sun ("Strength"),
    already multiplied into ``color``. ``direction`` is where the light points (sun, spot,
    area: the light's -Z axis). ``radius`` is the lamp's size: the radius of a point or spot,
    the half-size of an area lamp, the angular diameter of a sun in radians; it softens the
    shadows and widens the highlights (gpu_shaders/include/lighting.glsl). ``spot_size`` is
    the full cone angle in radians and
    ``spot_blend`` Blender's blend factor.

    Area lamps: ``radius`` is the half-size along the lamp's own x axis ``area_axis`` (unit,
    perpendicular to ``direction``), ``area_size_y`` the half-size along its y axis, and
    ``area_elliptic`` says whether the shape is a disk or an ellipse rather than a square or
    a rectangle (Blender's Shape). Their highlights and soft shadows take that shape; the
    light they shed is a cosine falloff over the hemisphere from the centre (documented
    approximation). Absent, an area lamp is a square of half-size ``radius`` whose x axis is
    ``area_basis(direction)[0]``.
    """

    kind: np.ndarray  # (L,) int32, LIGHT_*
    position: np.ndarray  # (L, 3) float32
    direction: np.ndarray  # (L, 3) float32, unit
    color: np.ndarray  # (L, 3) float32, colour * power
    radius: np.ndarray  # (L,) float32
    spot_size: np.ndarray  # (L,) float32, radians
    spot_blend: np.ndarray  # (L,) float32
    cast_shadow: np.ndarray  # (L,) bool
    names: list[str] = field(default_factory=list)
    area_axis: np.ndarray | None = None  # (L, 3) float32 unit x axis of area lamps
    area_size_y: np.ndarray | None = None  # (L,) float32 half-size along the y axis
    area_elliptic: np.ndarray | None = None  # (L,) bool: disk or ellipse
    sky_sun: int = 0  # the last rows are a Sky Texture's sun disc, added by SceneData (sky_sun.py)
    # Light linking: bit s of ``light_mask[i]`` says lamp i lights the objects of receiver
    # set s (MaterialTable.light_set), of ``shadow_mask[i]`` that the objects of blocker set
    # s cast its shadow (MaterialTable.shadow_set); None: every set (not linked).
    light_mask: np.ndarray | None = None  # (L,) uint64
    shadow_mask: np.ndarray | None = None  # (L,) uint64

    def __post_init__(self) -> None:
        self.kind = as_array(self.kind, np.int32, (), "kind")
        n = len(self.kind)
        for name in ("light_mask", "shadow_mask"):
            value = getattr(self, name)
            setattr(self, name, np.full(n, ALL_LINK_SETS, np.uint64) if value is None
                    else np.asarray(value, np.uint64).reshape(-1))
        self.position = as_array(self.position, np.float32, (3,), "position")
        self.direction = as_array(self.direction, np.float32, (3,), "direction")
        self.color = as_array(self.color, np.float32, (3,), "color")
        self.radius = as_array(self.radius, np.float32, (), "radius")
        self.spot_size = as_array(self.spot_size, np.float32, (), "spot_size")
        self.spot_blend = as_array(self.spot_blend, np.float32, (), "spot_blend")
        self.cast_shadow = as_array(self.cast_shadow, bool, (), "cast_shadow")
        if self.area_axis is None:
            self.area_axis = area_basis(self.direction)[0]
        self.area_axis = as_array(self.area_axis, np.float32, (3,), "area_axis")
        self.area_size_y = as_array(self.radius if self.area_size_y is None else self.area_size_y,
                                    np.float32, (), "area_size_y")
        self.area_elliptic = as_array(np.zeros(n, bool) if self.area_elliptic is None else self.area_elliptic,
                                      bool, (), "area_elliptic")
        for name in ("position", "direction", "color", "radius", "spot_size", "spot_blend", "cast_shadow",
                     "area_axis", "area_size_y", "area_elliptic", "light_mask", "shadow_mask"):
            if len(getattr(self, name)) != n:
                raise SceneDataError(f"light {name} has {len(getattr(self, name))} rows, expected {n}")
        if ((self.kind < 0) | (self.kind > LIGHT_AREA)).any():
            raise SceneDataError("light kind must be one of LIGHT_POINT/SUN/SPOT/AREA")
        if not self.names:
            self.names = [f"light_{i}" for i in range(n)]

    def __len__(self) -> int:
        return int(len(self.kind))

    def with_sky_sun(self, rows: list[dict]) -> "Lights":
        """These lights with ``rows`` (``from_rows``' dicts: a Sky Texture's sun disc, sky_sun.py)
        in place of the sky's rows they had: a scene made again from another's lights and sky
        keeps one sun, not two."""
        keep = len(self) - self.sky_sun
        more = Lights.from_rows(rows)
        arrays = {name: np.concatenate([getattr(self, name)[:keep], getattr(more, name)])
                  for name in ("kind", "position", "direction", "color", "radius", "spot_size", "spot_blend",
                               "cast_shadow", "area_axis", "area_size_y", "area_elliptic",
                               "light_mask", "shadow_mask")}  # the sky's sun lights every set
        return Lights(names=list(self.names[:keep]) + list(more.names), sky_sun=len(rows), **arrays)

    @classmethod
    def empty(cls) -> "Lights":
        return cls.from_rows([])

    @classmethod
    def from_rows(cls, rows: list[dict]) -> "Lights":
        """Build from dicts: kind ('POINT'|'SUN'|'SPOT'|'AREA' or int), position, direction,
        color (already times power), radius, spot_size, spot_blend, cast_shadow, name, for
        area lamps area_axis, area_size_y and area_elliptic (defaults: a square), and the
        linking masks light_mask and shadow_mask (default: every set); any other key is a
        ValueError."""
        check_row_keys(rows, _LIGHT_ROW_KEYS, "light")

        def kind_of(value):
            return LIGHT_KINDS[value] if isinstance(value, str) else int(value)

        directions = np.array([r.get("direction", (0, 0, -1)) for r in rows], np.float32).reshape(-1, 3)
        default_axes = area_basis(directions)[0]

        return cls(
            kind=np.array([kind_of(r.get("kind", "POINT")) for r in rows], np.int32),
            position=np.array([r.get("position", (0, 0, 0)) for r in rows], np.float32).reshape(-1, 3),
            direction=np.array([r.get("direction", (0, 0, -1)) for r in rows], np.float32).reshape(-1, 3),
            color=np.array([r.get("color", (1, 1, 1)) for r in rows], np.float32).reshape(-1, 3),
            radius=np.array([r.get("radius", 0.0) for r in rows], np.float32),
            spot_size=np.array([r.get("spot_size", np.pi / 4) for r in rows], np.float32),
            spot_blend=np.array([r.get("spot_blend", 0.15) for r in rows], np.float32),
            cast_shadow=np.array([r.get("cast_shadow", True) for r in rows], bool),
            names=[str(r.get("name", f"light_{i}")) for i, r in enumerate(rows)],
            area_axis=np.array([r.get("area_axis", default_axes[i]) for i, r in enumerate(rows)],
                               np.float32).reshape(-1, 3),
            area_size_y=np.array([r.get("area_size_y", r.get("radius", 0.0)) for r in rows], np.float32),
            area_elliptic=np.array([r.get("area_elliptic", False) for r in rows], bool),
            light_mask=np.array([r.get("light_mask", ALL_LINK_SETS) for r in rows], np.uint64),
            shadow_mask=np.array([r.get("shadow_mask", ALL_LINK_SETS) for r in rows], np.uint64),
        )


@dataclass
class Sky:
    """The World background: a constant colour, or an equirectangular environment image
    (Blender's convention: u = 0.5 - atan2(dir.y, dir.x) / 2π, v = 0.5 + atan2(dir.z, hypot(x, y)) / π),
    scaled by ``strength``; or the World's node graph (``graph``, its Background shader at the
    surface), which the GPU bakes into the environment per direction whenever the graph's
    values change (passes/lighting/world_bake.py) and which then replaces the other three.
    ``images`` holds the pixels its Environment Textures' ``texture`` settings index."""

    color: tuple[float, float, float] = (0.05, 0.05, 0.05)
    strength: float = 1.0
    environment: np.ndarray | None = None  # (H, W, 3) float32 linear, row 0 = bottom (v = 0)
    graph: ShaderGraph | None = None
    images: list[np.ndarray] = field(default_factory=list)

    def __post_init__(self) -> None:
        c = np.asarray(self.color, np.float32).reshape(-1)
        if c.shape != (3,) or not np.isfinite(c).all():
            raise SceneDataError(f"sky color must be 3 finite floats, got {self.color!r}")
        self.color = tuple(float(x) for x in c)
        if self.environment is not None:
            env = np.ascontiguousarray(np.asarray(self.environment, np.float32))
            if env.ndim != 3 or env.shape[2] not in (3, 4) or env.shape[0] < 1 or env.shape[1] < 1:
                raise SceneDataError(f"environment must be (H, W, 3|4), got {env.shape}")
            if env.shape[2] == 4:
                env = np.ascontiguousarray(env[:, :, :3])
            # The caller's array itself when it is clean: its identity tells the GPU side
            # (sky_light.py) that the environment did not change.
            self.environment = env if np.isfinite(env).all() else np.nan_to_num(env, nan=0.0, posinf=0.0,
                                                                                 neginf=0.0)
        if self.graph is not None:
            self.graph.validate()
        self.images = list(self.images)
        for k, image in enumerate(self.images):
            if image.ndim != 3 or image.shape[2] not in (3, 4) or image.shape[0] < 1 or image.shape[1] < 1:
                raise SceneDataError(f"world image {k} must be (H, W, 3|4), got {image.shape}")


@dataclass
class SceneData:
    """Everything one frame needs besides the camera and the settings."""

    geometry: Geometry
    materials: MaterialTable
    lights: Lights = field(default_factory=Lights.empty)
    sky: Sky = field(default_factory=Sky)

    @property
    def textures(self) -> list[np.ndarray]:
        """The scene's image textures; they live in the material table, next to the indices
        that refer to them, so a table can never be paired with the wrong list."""
        return self.materials.textures

    def __post_init__(self) -> None:
        if len(self.materials) == 0:
            raise SceneDataError("the material table needs at least one material (index 0 is the fallback)")
        self.geometry.clamp_material_ids(len(self.materials))
        # A Sky Texture's sun disc lights the scene as a sun lamp (sky_sun.py).
        sun = sun_rows(self.sky.graph)
        if sun or self.lights.sky_sun:
            self.lights = self.lights.with_sky_sun(sun)
