# SPDX-License-Identifier: GPL-3.0-or-later
"""The core's tables built from rows of keys (hybrid_engine/scene/data.py ``from_rows``): a key
the table does not read is an error, not a default."""
from __future__ import annotations

import pytest

from hybrid_engine.scene.data import Lights, MaterialTable
from hybrid_engine.scene.materials import principled_to_params


def test_a_material_row_key_the_table_does_not_read_is_rejected_with_the_rows_name():
    # Principled's names (metallic) are not the table's (reflectivity): taken silently, the
    # row would be the default grey diffuse.
    with pytest.raises(ValueError, match=r"material row 'floor'.*metallic"):
        MaterialTable.from_rows([dict(name="floor", base_color=(0.5, 0.5, 0.5), metallic=1.0)])
    rows = [principled_to_params(metallic=m) | {"name": "ok"} for m in (0.0, 1.0)]
    assert len(MaterialTable.from_rows(rows).names) == 2


def test_a_light_row_key_the_table_does_not_read_is_rejected_with_the_rows_name():
    # Blender's name for a lamp's power (energy) is not the table's (color, times the power).
    with pytest.raises(ValueError, match=r"light row 'key'.*energy"):
        Lights.from_rows([dict(name="key", kind="POINT", position=(0, 0, 3), energy=100.0)])
    assert len(Lights.from_rows([dict(name="key", kind="POINT", position=(0, 0, 3), color=(100.0,) * 3)])) == 1
