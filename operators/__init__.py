# SPDX-License-Identifier: GPL-3.0-or-later
"""Hybrid RT operators (the timing report operator, ``hybrid_rt.timing_report``, lands here)."""
from __future__ import annotations


def register() -> None:
    """Nothing to register yet."""


def unregister() -> None:
    """Nothing to unregister yet."""
