# SPDX-License-Identifier: GPL-3.0-or-later
"""The paper's Chess scene, built in code: 288 lathe-modelled pieces, nine mirror spheres.

The paper (§4, Figures 4, 6 and 7) calls its Chess scene "a pathological case" for
approximated reflections: 288 chess pieces and 9 spheres, almost all reflective, reflecting
and inter-reflecting each other, 2,149,944 triangles, animated over 200 frames with every
object dynamic. Its pieces are a commercial model, so this module rebuilds the scene's
character from code instead:

* **Layout**: nine complete sets (9 x 32 = 288 pieces) in their starting positions on a 3 x 3
  grid of 8 x 8 boards (squares 1 unit wide, board pitch :data:`BOARD_PITCH`), one dense mirror
  sphere over the middle of each board, a frame around each board and a large floor under
  everything (distant geometry for the cube map).
* **Pieces**: pawn, rook, bishop, queen and king are (r, z) profiles revolved around Z; the
  knight is a lathe base with an extruded (prism) head, the king carries a small box cross.
  Each piece type is tessellated once (a template), indexed as Blender stores a mesh, and
  placed by instances (``InstancedGeometry``), as the Blender adapter exports a scene: the
  GPU makes the world-space triangles, and a frame re-transforms only what moved.
* **Materials**: white pieces are white-tinted mirrors (reflectivity 0.8), black pieces
  dark-tinted mirrors (0.7), the white bishops clear glass (IOR 1.5), the spheres near-perfect
  mirrors, the board squares slightly reflective (as the paper's Figure 7 shows pieces
  reflected in the board). Thickness values (paper §3.4) are fractions of the cube map's far
  plane and assume :data:`CHESS_CUBE_FAR`: a piece stretches about one unit behind its
  cube-map depth, a sphere about two, the board is thin.
* **Detail**: ``detail`` scales both the profile resolution and the number of segments around
  Z by ``sqrt(detail)``, so the triangle count grows linearly with it: about 2.15 M triangles
  at ``detail=1`` (the paper's count), 1 M at 0.5; below about 0.05 the tessellation hits its
  floor (6 rings, 6 segments), which keeps ~20-30 k triangles for quick tests.
* **Animation** over :data:`CHESS_FRAMES` frames, periodic so that frame 200 equals frame 0:
  the camera orbits the grid once at varying distance and height, a pawn of every set
  advances two squares and back, a black knight of every set hops to f6 and back, the spheres
  circle and bob over their boards, and the middle sphere squashes and stretches (a
  deformation: the LBVH is rebuilt every frame, paper §3.3). The boards, frames and floor
  never move.
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from hybrid_engine.scene.camera import Camera, look_at
from hybrid_engine.scene.geometry import InstancedGeometry, flat_normals
from hybrid_engine.scene.meshes import Instances, ObjectMesh
from hybrid_engine.scene.data import Lights, MaterialTable, SceneData, Sky
from hybrid_engine.scene.solids import closed_outward

CHESS_FRAMES = 200  # length of the paper's animated sequences (§4)
# Far plane the thickness values below are chosen for (pass it as RenderSettings.cube_far).
CHESS_CUBE_FAR = 100.0
MAX_DETAIL = 4.0  # ~8.6 M triangles, several GB while building: beyond is almost surely a typo

SETS = 9
PIECES_PER_SET = 32
BOARD_SQUARES = 8
BOARD_PITCH = 10.5  # board centres 10.5 units apart: 8-unit boards, 0.25 frames, 2-unit gaps
FRAME_WIDTH = 0.25
BOARD_THICKNESS = 0.2
FLOOR_HALF_SIZE = 60.0

# Tessellation at detail 1 (both scale with sqrt(detail)) and its floor.
PROFILE_POINTS_AT_1 = 45
LATHE_SEGMENTS_AT_1 = 64
SPHERE_RINGS_AT_1 = 126  # 2 * rings segments around
MIN_PROFILE_POINTS = 6
MIN_SEGMENTS = 6

SPHERE_RADIUS = 0.85
KNIGHT_HEAD_HALF_WIDTH = 0.13

# Material slots (rows of the MaterialTable built below).
MAT_BOARD_LIGHT, MAT_BOARD_DARK, MAT_FRAME, MAT_FLOOR = 0, 1, 2, 3
MAT_WHITE_MIRROR, MAT_BLACK_MIRROR, MAT_GLASS, MAT_SPHERE = 4, 5, 6, 7

BACK_RANK = ("rook", "knight", "bishop", "queen", "king", "bishop", "knight", "rook")
PIECE_TYPES = ("pawn", "rook", "knight", "bishop", "queen", "king")


# -- profiles (r, z), bottom pole to top pole, one unit = one board square -----------------

def _arc(cx: float, cz: float, radius: float, start_deg: float, stop_deg: float,
         count: int) -> list[tuple[float, float]]:
    angles = np.radians(np.linspace(start_deg, stop_deg, count))
    return [(cx + radius * math.cos(a), cz + radius * math.sin(a)) for a in angles]


def _base(radius: float) -> list[tuple[float, float]]:
    """The common foot: a disc with a bevelled rim."""
    return [(0.0, 0.0), (radius, 0.0), (radius, 0.08), (radius - 0.05, 0.12),
            (radius - 0.05, 0.17), (radius - 0.12, 0.23)]


PROFILES: dict[str, list[tuple[float, float]]] = {
    "pawn": _base(0.34) + [(0.15, 0.32), (0.12, 0.48), (0.21, 0.52), (0.21, 0.56), (0.10, 0.60)]
    + _arc(0.0, 0.74, 0.16, -60.0, 90.0, 7),
    "rook": _base(0.36) + [(0.22, 0.70), (0.28, 0.74), (0.28, 0.78), (0.24, 0.80), (0.26, 0.84),
                           (0.30, 0.86), (0.30, 1.02), (0.20, 1.02), (0.20, 0.95), (0.0, 0.95)],
    "knight": _base(0.37) + [(0.22, 0.36), (0.0, 0.36)],
    "bishop": _base(0.36) + [(0.13, 0.62), (0.22, 0.66), (0.22, 0.70), (0.12, 0.74)]
    + _arc(0.0, 0.92, 0.17, -70.0, 80.0, 8) + _arc(0.0, 1.19, 0.06, -60.0, 90.0, 4),
    "queen": _base(0.38) + [(0.14, 0.80), (0.25, 0.85), (0.25, 0.89), (0.15, 0.93), (0.17, 1.05),
                            (0.27, 1.25), (0.24, 1.28), (0.12, 1.28)]
    + _arc(0.0, 1.36, 0.09, -60.0, 90.0, 5),
    "king": _base(0.38) + [(0.15, 0.86), (0.26, 0.91), (0.26, 0.95), (0.16, 0.99), (0.18, 1.10),
                           (0.25, 1.30), (0.25, 1.34), (0.08, 1.40), (0.0, 1.40)],
}

# The knight's head: a convex polygon in the (x, z) plane, snout towards +x, extruded along y.
KNIGHT_HEAD = np.array([(-0.22, 0.30), (0.18, 0.30), (0.42, 0.86), (0.38, 1.00),
                        (0.14, 1.18), (-0.10, 1.20), (-0.24, 0.96)], np.float64)
# The king's cross: two boxes (min corner, max corner).
KING_CROSS = (((-0.04, -0.04, 1.38), (0.04, 0.04, 1.70)), ((-0.12, -0.04, 1.52), (0.12, 0.04, 1.60)))


# -- tessellation ----------------------------------------------------------------------------

def tessellation(detail: float) -> dict[str, int]:
    """Profile points and segments of the lathe pieces and rings of the spheres at ``detail``."""
    scale = math.sqrt(detail)
    return {
        "profile_points": max(MIN_PROFILE_POINTS, round(PROFILE_POINTS_AT_1 * scale)),
        "segments": max(MIN_SEGMENTS, round(LATHE_SEGMENTS_AT_1 * scale)),
        "sphere_rings": max(MIN_SEGMENTS, round(SPHERE_RINGS_AT_1 * scale)),
    }


def resample_profile(points, count: int) -> np.ndarray:
    """``count`` points along a polyline, keeping its end points.

    With at least as many points as the polyline has, every control point (every corner) is
    kept and the extra points go to the segments in proportion to their length; with fewer,
    the points are spread uniformly by arc length (corners may be cut).
    """
    pts = np.asarray(points, np.float64)
    seg = np.diff(pts, axis=0)
    lengths = np.linalg.norm(seg, axis=1)
    if (lengths <= 0).any():
        raise ValueError("profile has repeated consecutive points")
    n = len(pts)
    if count >= n:
        extra = count - n
        share = extra * lengths / lengths.sum()
        alloc = np.floor(share).astype(int)
        remainder = extra - int(alloc.sum())
        if remainder:
            # Largest remainders first (stable: ties to the earlier segment).
            alloc[np.argsort(-(share - alloc), kind="stable")[:remainder]] += 1
        parts = [pts[i] + seg[i] * (np.arange(k + 1)[:, None] / (k + 1)) for i, k in enumerate(alloc)]
        return np.concatenate(parts + [pts[-1:]])
    arc = np.concatenate([[0.0], np.cumsum(lengths)])
    targets = np.linspace(0.0, arc[-1], count)
    return np.stack([np.interp(targets, arc, pts[:, 0]), np.interp(targets, arc, pts[:, 1])], axis=1)


def profile_normals(profile: np.ndarray) -> np.ndarray:
    """Outward (r, z) normals: the bisector of the adjacent segments' normals (smooth shading;
    one-sided at the poles, which gives -Z at the bottom and +Z at the top)."""
    seg = np.diff(profile, axis=0)
    seg /= np.linalg.norm(seg, axis=1, keepdims=True)
    tangent = np.zeros_like(profile)
    tangent[:-1] += seg
    tangent[1:] += seg
    length = np.linalg.norm(tangent, axis=1, keepdims=True)
    # A cusp (segments reversing direction) has no bisector: fall back to the next segment.
    fallback = np.concatenate([seg, seg[-1:]])
    tangent = np.where(length > 1e-9, tangent / np.maximum(length, 1e-9), fallback)
    # Profiles run upwards with r >= 0: the tangent rotated by -90 degrees points outwards.
    return np.stack([tangent[:, 1], -tangent[:, 0]], axis=1)


def lathe(profile: np.ndarray, normals: np.ndarray, segments: int) -> tuple[np.ndarray, np.ndarray]:
    """Revolve an (r, z) profile around Z: (T, 3, 3) triangles (counter-clockwise seen from
    outside) and smooth per-corner normals. The triangles collapsed at the poles (r = 0) are
    dropped, so a closed profile of P points gives 2 (P - 2) segments triangles."""
    phi = np.linspace(0.0, 2.0 * np.pi, segments + 1)
    cos, sin = np.cos(phi), np.sin(phi)
    cos[-1], sin[-1] = 1.0, 0.0  # close the seam exactly
    r, z = profile[:, 0:1], profile[:, 1:2]
    # Poles exactly on the axis (resampling leaves ~1e-17): the surface then closes there.
    r = np.where(np.abs(r) < 1e-9, 0.0, r)
    verts = np.stack([r * cos, r * sin, np.broadcast_to(z, r.shape[:1] + cos.shape)], axis=-1)
    nr, nz = normals[:, 0:1], normals[:, 1:2]
    norms = np.stack([nr * cos, nr * sin, np.broadcast_to(nz, nr.shape[:1] + cos.shape)], axis=-1)

    def quads(grid: np.ndarray) -> np.ndarray:
        a, b = grid[:-1, :-1], grid[:-1, 1:]
        c, d = grid[1:, 1:], grid[1:, :-1]
        return np.stack([np.stack([a, b, c], -2), np.stack([a, c, d], -2)], axis=2).reshape(-1, 3, 3)

    tris, tri_normals = quads(verts), quads(norms)
    area2 = np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1)
    keep = area2 > 1e-12
    return tris[keep], tri_normals[keep]


def quad(center, half_u, half_v) -> np.ndarray:
    """Two triangles spanning center +- half_u +- half_v, counter-clockwise seen from u x v."""
    c, u, v = (np.asarray(x, np.float64) for x in (center, half_u, half_v))
    a, b, cc, d = c - u - v, c + u - v, c + u + v, c - u + v
    return np.array([[a, b, cc], [a, cc, d]])


def box(lo, hi) -> np.ndarray:
    """12 outward-facing triangles of an axis-aligned box."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    c, h = (lo + hi) / 2, (hi - lo) / 2
    ex, ey, ez = np.diag(h)
    return np.concatenate([
        quad(c + ex, ey, ez), quad(c - ex, ez, ey), quad(c + ey, ez, ex),
        quad(c - ey, ex, ez), quad(c + ez, ex, ey), quad(c - ez, ey, ex),
    ])


def prism(polygon_xz: np.ndarray, half_width: float) -> np.ndarray:
    """A convex (x, z) polygon extruded along y by +-half_width: sides and two fan caps."""
    poly = np.asarray(polygon_xz, np.float64)
    edges = np.roll(poly, -1, axis=0) - poly
    turn = edges[:, 0] * np.roll(edges, -1, axis=0)[:, 1] - edges[:, 1] * np.roll(edges, -1, axis=0)[:, 0]
    if not ((turn > 0).all() or (turn < 0).all()):
        raise ValueError("prism() needs a convex polygon (its caps are triangle fans)")
    front = np.stack([poly[:, 0], np.full(len(poly), -half_width), poly[:, 1]], axis=1)
    back = front + np.array([0.0, 2.0 * half_width, 0.0])
    nxt = np.roll(np.arange(len(poly)), -1)
    sides = np.concatenate([np.stack([front, front[nxt], back[nxt]], 1),
                            np.stack([front, back[nxt], back], 1)])
    fan = np.arange(1, len(poly) - 1)
    caps = np.concatenate([np.stack([front[np.zeros_like(fan)], front[fan + 1], front[fan]], 1),
                           np.stack([back[np.zeros_like(fan)], back[fan], back[fan + 1]], 1)])
    tris = np.concatenate([sides, caps])
    # Orient every face away from the prism's centre (the polygon's winding is arbitrary).
    centre = np.array([poly[:, 0].mean(), 0.0, poly[:, 1].mean()])
    normal = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    inward = np.einsum("ij,ij->i", normal, tris.mean(axis=1) - centre) < 0
    tris[inward] = tris[inward][:, ::-1]
    return tris


@lru_cache(maxsize=8)
def piece_templates(detail: float) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """(triangles, normals) of each piece type and of the unit sphere at ``detail``, float32,
    in the piece's own frame (standing on z = 0, facing +x). Cached: the templates do not
    depend on the frame."""
    tess = tessellation(detail)
    out: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for name in PIECE_TYPES:
        profile = resample_profile(PROFILES[name], tess["profile_points"])
        tris, normals = lathe(profile, profile_normals(profile), tess["segments"])
        extras = []
        if name == "knight":
            extras.append(prism(KNIGHT_HEAD, KNIGHT_HEAD_HALF_WIDTH))
        if name == "king":
            extras.extend(box(lo, hi) for lo, hi in KING_CROSS)
        if extras:
            extra = np.concatenate(extras)
            tris = np.concatenate([tris, extra])
            normals = np.concatenate([normals, flat_normals(extra)])
        out[name] = (tris.astype(np.float32), normals.astype(np.float32))
    rings = tess["sphere_rings"]
    theta = np.linspace(0.0, np.pi, rings + 1)
    sphere_profile = np.stack([np.sin(theta), -np.cos(theta)], axis=1)
    sphere_profile[0, 0] = sphere_profile[-1, 0] = 0.0
    tris, normals = lathe(sphere_profile, sphere_profile, 2 * rings)
    out["sphere"] = (tris.astype(np.float32), normals.astype(np.float32))
    return out


@lru_cache(maxsize=8)
def template_closed(detail: float) -> dict[str, bool]:
    """Which templates at ``detail`` are closed, outward-wound surfaces (all of them; checked,
    not assumed, since a lathe profile that misses the axis leaves a hole)."""
    return {name: closed_outward(tris) for name, (tris, _) in piece_templates(detail).items()}


def chess_triangle_count(detail: float = 1.0) -> int:
    """Triangles of :func:`build_chess` at ``detail`` (without building the scene)."""
    detail = _check_detail(detail)
    templates = piece_templates(detail)
    per_set = sum(len(templates[name][0]) * count for name, count in
                  (("pawn", 16), ("rook", 4), ("knight", 4), ("bishop", 4), ("queen", 2), ("king", 2)))
    return SETS * (per_set + len(templates["sphere"][0]) + len(_board_top()[0]) + len(_board_frame())) + 2


# -- the static parts -------------------------------------------------------------------------

def board_centers() -> np.ndarray:
    """(9, 3) centres of the boards' top faces, row-major over the 3 x 3 grid."""
    offsets = (np.arange(3) - 1) * BOARD_PITCH
    gx, gy = np.meshgrid(offsets, offsets)
    return np.stack([gx.ravel(), gy.ravel(), np.zeros(9)], axis=1)


def _board_top() -> tuple[np.ndarray, np.ndarray]:
    """One board centred on the origin: 64 squares (two alternating materials) on a slab."""
    idx = np.arange(BOARD_SQUARES)
    col, row = np.meshgrid(idx, idx)
    centres = np.stack([col.ravel() - 3.5, row.ravel() - 3.5, np.zeros(64)], axis=1)
    squares = np.concatenate([quad(c, (0.5, 0, 0), (0, 0.5, 0)) for c in centres])
    # a1 (col 0, row 0) is dark, as on a real board.
    square_mats = np.where((col.ravel() + row.ravel()) % 2 == 0, MAT_BOARD_DARK, MAT_BOARD_LIGHT)
    half = BOARD_SQUARES / 2
    slab = box((-half, -half, -BOARD_THICKNESS), (half, half, 0.0))
    slab = slab[np.abs(flat_normals(slab)[:, 0, 2] - 1.0) > 1e-6]  # its top is the squares
    tris = np.concatenate([squares, slab])
    mats = np.concatenate([np.repeat(square_mats, 2), np.full(len(slab), MAT_BOARD_DARK)])
    return tris, mats


def _board_frame() -> np.ndarray:
    half, outer = BOARD_SQUARES / 2, BOARD_SQUARES / 2 + FRAME_WIDTH
    z0, z1 = -BOARD_THICKNESS, 0.04
    return np.concatenate([
        box((-outer, half, z0), (outer, outer, z1)), box((-outer, -outer, z0), (outer, -half, z1)),
        box((-outer, -half, z0), (-half, half, z1)), box((half, -half, z0), (outer, half, z1)),
    ])


# -- pieces and their motion ------------------------------------------------------------------

def _set_layout() -> list[tuple[str, str, int, int]]:
    """(type, colour, column, row) of the 32 pieces of one set in the starting position."""
    layout = []
    for colour, back, pawns in (("white", 0, 1), ("black", 7, 6)):
        layout.extend((kind, colour, c, back) for c, kind in enumerate(BACK_RANK))
        layout.extend(("pawn", colour, c, pawns) for c in range(BOARD_SQUARES))
    return layout


def _rotation_z(angles: np.ndarray) -> np.ndarray:
    c, s = np.cos(angles), np.sin(angles)
    rot = np.zeros((len(angles), 3, 3))
    rot[:, 0, 0], rot[:, 0, 1], rot[:, 1, 0], rot[:, 1, 1] = c, -s, s, c
    rot[:, 2, 2] = 1.0
    return rot


def _wave(frame: int) -> tuple[float, float]:
    """(phase t in [0, 1), smooth back-and-forth w in [0, 1]) of a frame; period CHESS_FRAMES."""
    t = (frame % CHESS_FRAMES) / CHESS_FRAMES
    return t, 0.5 - 0.5 * math.cos(2.0 * math.pi * t)


def piece_placements(frame: int) -> list[dict]:
    """Every piece's type, name, material, position and heading at ``frame``."""
    t, w = _wave(frame)
    pieces = []
    for board, centre in enumerate(board_centers()):
        for kind, colour, col, row in _set_layout():
            x, y, z = col - 3.5, row - 3.5, 0.0
            # Moving pieces: the a-pawn advances two squares and back, the g8 knight hops to f6.
            if kind == "pawn" and colour == "white" and col == 0:
                y += 2.0 * w
            if kind == "knight" and colour == "black" and col == 6:
                x, y = x - w, y - 2.0 * w
                z = 1.0 * math.sin(math.pi * w)
            material = MAT_WHITE_MIRROR if colour == "white" else MAT_BLACK_MIRROR
            if kind == "bishop" and colour == "white":
                material = MAT_GLASS
            pieces.append({
                "kind": kind, "name": f"set{board}_{colour}_{kind}_{'abcdefgh'[col]}{row + 1}",
                "material": material, "position": centre + (x, y, z),
                # Knights (and the king's cross) face the opponent.
                "angle": math.pi / 2 if colour == "white" else -math.pi / 2,
            })
    return pieces


def sphere_placements(frame: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-sphere (9, 3, 3) linear maps (scale) and (9, 3) centres at ``frame``: each circles
    and bobs over its board's middle; the middle one squashes and stretches."""
    t, _ = _wave(frame)
    phase = np.arange(SETS) * (2.0 * np.pi / SETS)
    angle = 2.0 * np.pi * t + phase
    stretch = np.ones(SETS)
    stretch[SETS // 2] = 1.0 + 0.2 * math.sin(4.0 * math.pi * t)
    lift = 0.1 + 0.4 * (0.5 + 0.5 * np.sin(4.0 * np.pi * t + phase))
    centres = board_centers() + np.stack(
        [0.5 * np.cos(angle), 0.5 * np.sin(angle), SPHERE_RADIUS * stretch + lift], axis=1)
    maps = np.zeros((SETS, 3, 3))
    maps[:, 0, 0] = maps[:, 1, 1] = SPHERE_RADIUS
    maps[:, 2, 2] = SPHERE_RADIUS * stretch
    return maps, centres


def camera_path(frame: int, width: int, height: int) -> Camera:
    """The animated camera: one orbit of the grid in CHESS_FRAMES frames at 7 to 9.5 units
    from its centre and 2.4 to 3.6 above the boards (always clear of pieces and spheres),
    looking across the grid so that a few pieces are near and most are far."""
    t, _ = _wave(frame)
    angle = math.pi / 5 + 2.0 * math.pi * t
    radius = 8.25 - 1.25 * math.sin(4.0 * math.pi * t)
    height_above = 3.0 + 0.6 * math.sin(6.0 * math.pi * t)
    eye = (radius * math.cos(angle), radius * math.sin(angle), height_above)
    target = (0.3 * radius * math.cos(angle + 0.5), 0.3 * radius * math.sin(angle + 0.5), 0.3)
    return Camera(matrix_world=look_at(eye, target), width=int(width), height=int(height),
                  lens=24.0, clip_start=0.05, clip_end=200.0)


# -- assembly ---------------------------------------------------------------------------------

def chess_materials() -> MaterialTable:
    return MaterialTable.from_rows([
        dict(name="board_light", base_color=(0.85, 0.80, 0.70), reflectivity=0.2, thickness=0.002),
        dict(name="board_dark", base_color=(0.10, 0.08, 0.07), reflectivity=0.3, thickness=0.002),
        dict(name="board_frame", base_color=(0.35, 0.18, 0.08), thickness=0.002),
        dict(name="floor", base_color=(0.45, 0.45, 0.45), thickness=0.0),
        dict(name="piece_white_mirror", base_color=(0.95, 0.93, 0.88), reflectivity=0.8,
             thickness=0.01),
        dict(name="piece_black_mirror", base_color=(0.30, 0.30, 0.33), reflectivity=0.7,
             thickness=0.01),
        dict(name="piece_glass", base_color=(1.0, 1.0, 1.0), transmission=1.0, ior=1.5,
             thickness=0.01),
        dict(name="sphere_mirror", base_color=(0.95, 0.95, 0.95), reflectivity=0.9,
             thickness=0.02),
    ])


def chess_sky() -> Sky:
    """A clear blue sky, the only light source besides the sun and the lamp."""
    return Sky(color=(0.45, 0.60, 0.85), strength=1.0)


def chess_lights() -> Lights:
    """A sun (irradiance 3 W/m², low from the south-west) and a warm point light over the grid."""
    sun_dir = np.array([0.45, 0.35, -1.0])
    return Lights.from_rows([
        dict(kind="SUN", direction=tuple(sun_dir / np.linalg.norm(sun_dir)),
             color=(3.0, 2.9, 2.7), name="sun"),
        dict(kind="POINT", position=(0.0, 0.0, 9.0), color=(1500.0, 1300.0, 1000.0),
             radius=0.5, name="lamp"),
    ])


def _check_detail(detail: float) -> float:
    detail = float(detail)
    if not (math.isfinite(detail) and 0.0 < detail <= MAX_DETAIL):
        raise ValueError(f"detail must lie in (0, {MAX_DETAIL}], got {detail}")
    return detail


def indexed_mesh(triangles: np.ndarray, normals: np.ndarray, slots, closed: bool) -> ObjectMesh:
    """A triangle list as Blender stores a mesh: each distinct vertex and normal once, the
    corners indexing them (the exporter's ObjectMesh; blender_adapter/export/meshes.py)."""
    tris = np.asarray(triangles, np.float32).reshape(-1, 3)
    positions, corner_vertices = np.unique(tris, axis=0, return_inverse=True)
    unique_normals, corner_normals = np.unique(np.asarray(normals, np.float32).reshape(-1, 3), axis=0,
                                               return_inverse=True)
    count = len(tris) // 3
    return ObjectMesh(positions=positions, corner_vertices=corner_vertices.reshape(-1).astype(np.int32),
                      normals=unique_normals, corner_normals=corner_normals.reshape(-1).astype(np.int32),
                      slots=np.broadcast_to(np.asarray(slots, np.int32), (count,)).copy(), closed=closed)


@lru_cache(maxsize=4)
def chess_meshes(detail: float) -> dict[str, ObjectMesh]:
    """Every mesh of the scene at ``detail``, made once and shared by all frames (and by all
    the instances of a piece type), as the Blender adapter keeps an evaluated mesh: frames
    then differ only in their instance matrices, so the GPU re-transforms what moved."""
    templates = piece_templates(detail)
    closed = template_closed(detail)
    meshes = {name: indexed_mesh(tris, normals, 0, closed[name]) for name, (tris, normals) in templates.items()}
    board_tris, board_mats = _board_top()
    frame_tris = _board_frame()
    floor = quad((0.0, 0.0, -BOARD_THICKNESS), (FLOOR_HALF_SIZE, 0, 0), (0, FLOOR_HALF_SIZE, 0))
    meshes["board"] = indexed_mesh(board_tris, flat_normals(board_tris), board_mats, False)
    meshes["board_frame"] = indexed_mesh(frame_tris, flat_normals(frame_tris), 0, False)
    meshes["floor"] = indexed_mesh(floor, flat_normals(floor), 0, False)
    return meshes


def _matrices(linear: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """(n, 4, 4) object-to-world matrices of linear maps (n, 3, 3) and translations (n, 3)."""
    out = np.zeros((len(offsets), 4, 4))
    out[:, :3, :3] = linear
    out[:, :3, 3] = offsets
    out[:, 3, 3] = 1.0
    return out


def build_chess(detail: float = 1.0, frame: int = 0, width: int = 640,
                height: int = 360) -> tuple[SceneData, Camera]:
    """The Chess scene at ``frame`` (see the module docstring) and its camera at
    ``width`` x ``height``, built as the Blender adapter exports a scene: shared object-space
    meshes placed by instances (``InstancedGeometry``), the path every frame the artist
    renders takes. Raises ValueError for a detail outside (0, MAX_DETAIL]."""
    detail = _check_detail(detail)
    frame = int(frame)
    meshes = chess_meshes(detail)
    pieces = piece_placements(frame)
    sphere_maps, sphere_centres = sphere_placements(frame)
    centres = board_centers()
    identity = np.broadcast_to(np.eye(3), (SETS, 3, 3))
    all_materials = np.arange(MAT_SPHERE + 1, dtype=np.int32)

    # (mesh, names, matrices, slot materials): the static parts, then the spheres and the
    # pieces type by type (the order of the objects, and so of their triangles).
    groups = [("floor", ["floor"], _matrices(np.eye(3)[None], np.zeros((1, 3))), [np.array([MAT_FLOOR])]),
              ("board", [f"board_{b}" for b in range(SETS)], _matrices(identity, centres), [all_materials] * SETS),
              ("board_frame", [f"board_frame_{b}" for b in range(SETS)], _matrices(identity, centres),
               [np.array([MAT_FRAME])] * SETS),
              ("sphere", [f"sphere_{b}" for b in range(SETS)], _matrices(sphere_maps, sphere_centres),
               [np.array([MAT_SPHERE])] * SETS)]
    for kind in PIECE_TYPES:
        chosen = [p for p in pieces if p["kind"] == kind]
        groups.append((kind, [p["name"] for p in chosen],
                       _matrices(_rotation_z(np.array([p["angle"] for p in chosen])),
                                 np.array([p["position"] for p in chosen])),
                       [np.array([p["material"]]) for p in chosen]))
    order = list(meshes)
    names, mesh_index, matrices, slot_materials = [], [], [], []
    for mesh, group_names, group_matrices, group_slots in groups:
        names += group_names
        mesh_index += [order.index(mesh)] * len(group_names)
        matrices.append(group_matrices)
        slot_materials += group_slots
    instances = Instances(meshes=[meshes[name] for name in order], mesh=np.array(mesh_index, np.int32),
                          matrices=np.concatenate(matrices).astype(np.float32), slot_materials=slot_materials)
    scene = SceneData(geometry=InstancedGeometry(instances, names), materials=chess_materials(),
                      lights=chess_lights(), sky=chess_sky())
    return scene, camera_path(frame, width, height)
