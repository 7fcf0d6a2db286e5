# SPDX-License-Identifier: GPL-3.0-or-later
"""Culling the triangles to the near cube (paper §3.3; GLSL in gpu_shaders/near_cube_cull/)."""
