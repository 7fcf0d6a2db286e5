# SPDX-License-Identifier: GPL-3.0-or-later
"""The diagnostic views' legend, painted into the rendered pixels with a bitmap font.

Why a bitmap font: the legend must sit in the image itself (F12's Combined pass and the
viewport's texture are float arrays the engine fills), so that a saved render keeps it.
Blender's font engine draws only into an ImBuf (``blf.bind_imbuf``), whose pixels Python
can neither hand in nor read back without a round trip through a file; a render pass
cannot wait on that. So this one module keeps a 3x5 bitmap font (upper-case letters,
digits, the punctuation labels need), scaled by whole pixels. The legend is data until
here (``FrameResult.legend``): the renderer core never paints text, the Blender adapter
calls ``draw_legend`` on what it shows.
"""
from __future__ import annotations

import numpy as np

from ..passes.trace.diagnostic_views import LegendEntry

RGB = tuple[float, float, float]

LEGEND_SCALE = 2  # font pixels per glyph pixel
LEGEND_TEXT: RGB = (1.0, 1.0, 1.0)
LEGEND_BACKGROUND: RGB = (0.01, 0.01, 0.01)

# ---------------------------------------------------------------------------------------------
# A 3x5 bitmap font: upper-case letters, digits and the punctuation labels need. Lower case
# is drawn upper case; any other character is drawn as '?'.

_GLYPH_ROWS = {
    "0": "111 101 101 101 111", "1": "010 110 010 010 111", "2": "111 001 111 100 111",
    "3": "111 001 111 001 111", "4": "101 101 111 001 001", "5": "111 100 111 001 111",
    "6": "111 100 111 101 111", "7": "111 001 001 010 010", "8": "111 101 111 101 111",
    "9": "111 101 111 001 111", "A": "010 101 111 101 101", "B": "110 101 110 101 110",
    "C": "011 100 100 100 011", "D": "110 101 101 101 110", "E": "111 100 110 100 111",
    "F": "111 100 110 100 100", "G": "011 100 101 101 011", "H": "101 101 111 101 101",
    "I": "111 010 010 010 111", "J": "001 001 001 101 010", "K": "101 101 110 101 101",
    "L": "100 100 100 100 111", "M": "101 111 111 101 101", "N": "110 101 101 101 101",
    "O": "010 101 101 101 010", "P": "110 101 110 100 100", "Q": "010 101 101 110 011",
    "R": "110 101 110 101 101", "S": "011 100 010 001 110", "T": "111 010 010 010 010",
    "U": "101 101 101 101 111", "V": "101 101 101 101 010", "W": "101 101 111 111 101",
    "X": "101 101 010 101 101", "Y": "101 101 010 010 010", "Z": "111 001 010 100 111",
    " ": "000 000 000 000 000", ".": "000 000 000 000 010", ",": "000 000 000 010 100",
    "-": "000 000 111 000 000", "_": "000 000 000 000 111", ":": "000 010 000 010 000",
    "/": "001 001 010 100 100", "%": "101 001 010 100 101", "(": "010 100 100 100 010",
    ")": "010 001 001 001 010", "=": "000 111 000 111 000", "+": "000 010 111 010 000",
    "?": "111 001 010 000 010", "#": "101 111 101 111 101",
}
GLYPHS: dict[str, np.ndarray] = {
    char: np.array([[bit == "1" for bit in row] for row in rows.split()], dtype=bool)
    for char, rows in _GLYPH_ROWS.items()
}
GLYPH_WIDTH, GLYPH_HEIGHT = 3, 5
GLYPH_ADVANCE = GLYPH_WIDTH + 1  # one blank column between characters


def text_mask(text: str, scale: int = 2) -> np.ndarray:
    """The pixels of ``text`` as a boolean (5*scale, (4*len-1)*scale) mask."""
    if not text:
        return np.zeros((GLYPH_HEIGHT * scale, 0), dtype=bool)
    columns = []
    for index, char in enumerate(text.upper()):
        if index:
            columns.append(np.zeros((GLYPH_HEIGHT, 1), dtype=bool))
        columns.append(GLYPHS.get(char, GLYPHS["?"]))
    mask = np.concatenate(columns, axis=1)
    return np.kron(mask, np.ones((scale, scale), dtype=bool)).astype(bool)


def text_width(text: str, scale: int = 2) -> int:
    return max(len(text) * GLYPH_ADVANCE - 1, 0) * scale


def draw_text(image: np.ndarray, text: str, x: int, y: int, color: RGB = LEGEND_TEXT, scale: int = 2,
              align: str = "left") -> None:
    """Draw ``text`` with its top edge at row ``y``; ``x`` is its left edge, centre or right
    edge for ``align`` 'left', 'center' or 'right'. Pixels outside the image are dropped."""
    mask = text_mask(text, scale)
    if align == "center":
        x -= mask.shape[1] // 2
    elif align == "right":
        x -= mask.shape[1]
    _paint_mask(image, mask, x, y, color)


def _paint_mask(image: np.ndarray, mask: np.ndarray, x: int, y: int, color: RGB) -> None:
    height, width = image.shape[:2]
    # Clip the mask to the image.
    top, left = max(y, 0), max(x, 0)
    bottom, right = min(y + mask.shape[0], height), min(x + mask.shape[1], width)
    if bottom <= top or right <= left:
        return
    clipped = mask[top - y: bottom - y, left - x: right - x]
    image[top:bottom, left:right][clipped] = color


def fill_rect(image: np.ndarray, x0: int, y0: int, x1: int, y1: int, color: RGB) -> None:
    """Fill columns [x0, x1) and rows [y0, y1), clipped to the image."""
    height, width = image.shape[:2]
    x0, x1 = max(int(x0), 0), min(int(x1), width)
    y0, y1 = max(int(y0), 0), min(int(y1), height)
    if x1 > x0 and y1 > y0:
        image[y0:y1, x0:x1] = color



def draw_legend(image: np.ndarray, entries: list[LegendEntry]) -> None:
    """Paint ``entries`` (a swatch and a label each) into the top-left corner of ``image``
    ((H, W, 4) float linear RGBA, row 0 at the bottom), clipped to the image."""
    if not entries:
        return
    s = LEGEND_SCALE
    row = GLYPH_HEIGHT * s + 2 * s
    swatch = GLYPH_HEIGHT * s
    width = 3 * s + swatch + 2 * s + max(text_width(e.label, s) for e in entries) + 3 * s
    height = len(entries) * row + 4 * s
    panel = np.empty((height, width, 3), np.float32)
    panel[:] = LEGEND_BACKGROUND
    for i, entry in enumerate(entries):
        y = 2 * s + i * row
        fill_rect(panel, 3 * s, y, 3 * s + swatch, y + swatch, entry.colour)
        draw_text(panel, entry.label, 3 * s + swatch + 2 * s, y, LEGEND_TEXT, s)
    h, w = image.shape[:2]
    height, width = min(height, h), min(width, w)
    # The panel's row 0 is its top; the image's is its bottom.
    image[h - height:, :width, :3] = panel[:height, :width][::-1]
    image[h - height:, :width, 3] = 1.0
