# SPDX-License-Identifier: GPL-3.0-or-later
"""hybrid_engine/reports/diagnostic_legend.py: the legend's bitmap font."""
from __future__ import annotations

import numpy as np

from hybrid_engine.reports import diagnostic_legend
from hybrid_engine.reports.diagnostic_legend import text_mask, text_width


def test_every_glyph_is_distinct_and_three_by_five():
    shapes = {glyph.shape for glyph in diagnostic_legend.GLYPHS.values()}
    assert shapes == {(5, 3)}
    patterns = [glyph.tobytes() for char, glyph in diagnostic_legend.GLYPHS.items() if char != " "]
    assert len(set(patterns)) == len(patterns)


def test_text_mask_size_and_fallbacks():
    assert text_mask("ab12", scale=2).shape == (10, text_width("ab12", 2)) == (10, 30)
    np.testing.assert_array_equal(text_mask("ms"), text_mask("MS"))  # lower case drawn upper case
    np.testing.assert_array_equal(text_mask("~"), text_mask("?"))  # unknown characters
    assert text_mask("", 3).shape == (15, 0)
