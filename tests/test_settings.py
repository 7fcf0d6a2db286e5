# SPDX-License-Identifier: GPL-3.0-or-later
"""Render settings (hybrid_engine/scene/settings.py): the near cube's Frame Budget limits are
checked with the rest."""
from __future__ import annotations

import pytest

from hybrid_engine.scene.settings import RenderSettings, SettingsError


def test_a_budget_whose_minimum_exceeds_its_maximum_is_refused():
    with pytest.raises(SettingsError, match="near_min"):
        RenderSettings(near_cube_mode="BUDGET", near_min=5.0, near_max=1.0)


def test_a_budget_whose_largest_cube_reaches_the_far_clip_is_refused_and_fixed_mode_ignores_it():
    with pytest.raises(SettingsError, match="near_max"):
        RenderSettings(near_cube_mode="BUDGET", near_max=50.0, cube_far=40.0, near_size=1.0)
    RenderSettings(near_cube_mode="FIXED", near_max=50.0, cube_far=40.0, near_size=1.0)


def test_an_unknown_near_cube_mode_is_refused():
    with pytest.raises(SettingsError, match="near_cube_mode"):
        RenderSettings(near_cube_mode="AUTO")
