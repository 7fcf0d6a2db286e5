# SPDX-License-Identifier: GPL-3.0-or-later
"""The frame: the renderer that runs the passes in order, film and data passes, sample accumulation, the near cube's budget, the viewport's view."""
