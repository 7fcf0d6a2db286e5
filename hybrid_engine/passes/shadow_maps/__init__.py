# SPDX-License-Identifier: GPL-3.0-or-later
"""Shadow maps of every lamp, in static and dynamic layers, with sun cascades (paper §3.5; GLSL in gpu_shaders/shadow_maps/)."""
